"""Whole-or-nothing file writes keep the permissions an ordinary write gives."""
import os
import stat
import sys

import pytest

from flank_addon.io.files import atomic_write, output_path_error

posix_only = pytest.mark.skipif(sys.platform == "win32", reason="POSIX permission bits")


def _mode(path):
    return stat.S_IMODE(os.stat(path).st_mode)


@posix_only
@pytest.mark.parametrize("umask, expected", [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_a_new_file_gets_the_mode_the_umask_allows(tmp_path, umask, expected):
    old = os.umask(umask)
    try:
        atomic_write(tmp_path / "prog.ngc", "G0 X1\n")
        assert os.umask(umask) == umask                   # the write put the umask back
    finally:
        os.umask(old)
    assert _mode(tmp_path / "prog.ngc") == expected
    assert (tmp_path / "prog.ngc").read_text() == "G0 X1\n"


@posix_only
def test_a_replaced_file_keeps_its_mode(tmp_path):
    path = tmp_path / "plan.json"
    path.write_text("{}")
    os.chmod(path, 0o640)
    atomic_write(path, b"{\"format\": 1}")
    assert _mode(path) == 0o640 and path.read_bytes() == b"{\"format\": 1}"
    assert os.listdir(tmp_path) == ["plan.json"]


@posix_only
def test_a_link_is_written_through_and_a_device_is_refused(tmp_path):
    real, link = tmp_path / "real.ngc", tmp_path / "current.ngc"
    real.write_text("OLD")
    os.symlink(real, link)
    atomic_write(link, "G0 X1\n")
    assert os.path.islink(link) and real.read_text() == "G0 X1\n"
    with pytest.raises(OSError) as e:
        atomic_write("/dev/null", "G0 X1\n")
    assert e.value.filename == "/dev/null" and "not a regular file" in e.value.strerror
    assert os.path.exists("/dev/null") and not os.path.isfile("/dev/null")


def test_an_output_path_is_judged_before_any_work(tmp_path):
    """A folder, a missing folder, a file in the way of a folder; a prefix names files that begin with it."""
    afile = tmp_path / "afile"
    afile.write_text("x")
    assert output_path_error(tmp_path / "new.json") is None
    assert output_path_error(tmp_path) == f"{tmp_path} is a folder: give a file name"
    assert output_path_error(tmp_path / "nope" / "p.ngc") == f"the folder {tmp_path / 'nope'} does not exist"
    assert output_path_error(afile / "p.ngc") == f"{afile} is not a folder"
    # PREFIX_<k>.stl: "out/" is the folder out itself, "out/strip" a prefix inside it
    assert output_path_error(str(tmp_path) + "/", prefix=True) is None
    assert output_path_error(tmp_path / "strip", prefix=True) is None
    assert output_path_error(str(tmp_path / "nope") + "/", prefix=True) == f"the folder {tmp_path / 'nope'} does not exist"
