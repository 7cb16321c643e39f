import contextlib
import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from flank_addon.cli import main
from flank_addon.io.plan import PlanError, new_plan, read_plan, rotor_section, validate_plan, write_plan
from flank_addon.geometry.rotors import builtin_by_name

ROOT = Path(__file__).resolve().parents[1]


def run_cli(*args):
    """The CLI as ``python -m flank_addon`` runs it: its exit code and what it printed."""
    return subprocess.run([sys.executable, "-m", "flank_addon", *map(str, args)], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)


def main_cli(*args):
    """The CLI's main() in this process (no interpreter start and imports per call): its return code and what
    it printed, as :func:`run_cli` gives them.  An uncaught exception fails the test as a traceback would."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return subprocess.CompletedProcess(args, code, out.getvalue(), err.getvalue())


def sample_plan():
    rotor = builtin_by_name("asymmetric-female")
    section = rotor_section(rotor.profile, rotor.v0, rotor.handedness, rotor.flanks)
    strip = {"axis_start": [0.5, 0.0, 0.0], "axis_end": [0.7, 0.0, 0.3], "radii": [0.1, 0.15],
             "shank_start": [0.7, 0.0, 0.3], "shank_end": [0.9, 0.0, 0.8], "shank_radius": 0.15, "flank": 1,
             "reported_max_error": 0.002, "reported_min_error": -0.0005, "collision": False}
    return new_plan("test", section, {"kind": "cone", "r1": 0.1, "r2": 0.15, "length": 0.2},
                    target_flanks=[1], strips=[strip], elapsed_s=0.1)


def test_plan_round_trip_and_summary(tmp_path):
    plan = sample_plan()
    assert plan["summary"]["max_error"] == 0.002 and plan["summary"]["min_error"] == -0.0005
    assert len(plan["rotor"]["profile"]) >= 720 and len(plan["rotor"]["flanks"]) == 12
    path = tmp_path / "p.json"
    write_plan(path, plan)
    again = read_plan(path)
    assert again == json.loads(json.dumps(plan))
    # flank index ranges follow the rotor's parameter ranges: tip -> bottom radii decrease
    prof = np.asarray(plan["rotor"]["profile"])
    a, b = plan["rotor"]["flanks"][0]
    r = np.linalg.norm(prof, axis=1)
    assert r[a % len(r)] > r[b % len(r)]


def test_write_plan_is_atomic_and_names_the_file(tmp_path, monkeypatch):
    """A plan file is the old one or the complete new one; a failed write names the file asked for and leaves
    no temporary file behind.  The text has one line per top-level field and per strip."""
    import os

    plan = sample_plan()
    path = tmp_path / "p.json"
    write_plan(path, plan)
    lines = path.read_text().splitlines()
    assert lines[0] == "{" and lines[-1] == "}" and len(lines) == len(plan) + 2 + len(plan["strips"]) + 1
    old = path.read_bytes()

    def failing_replace(src, dst):
        raise OSError(28, "No space left on device", src)

    changed = dict(plan, method="other")
    monkeypatch.setattr(os, "replace", failing_replace)
    with pytest.raises(OSError) as e:
        write_plan(path, changed)
    monkeypatch.undo()
    assert e.value.filename == str(path) and "No space" in e.value.strerror
    assert path.read_bytes() == old and sorted(p.name for p in tmp_path.iterdir()) == ["p.json"]
    r = main_cli("verify", path, "--json")          # the old plan still reads
    assert r.returncode == 0, r.stderr
    with pytest.raises(OSError) as e:
        write_plan(tmp_path / "missing" / "q.json", plan)
    assert e.value.filename == str(tmp_path / "missing" / "q.json")


@pytest.mark.parametrize("mutate, message", [
    (lambda p: p.update(schema="flank-plan/0"), "schema"),
    (lambda p: p["rotor"].update(v0=-1.0), "rotor.v0"),
    (lambda p: p["rotor"].update(handedness="up"), "rotor.handedness"),
    (lambda p: p["rotor"].update(profile=p["rotor"]["profile"][:100]), "at least 720"),
    (lambda p: p["rotor"].update(profile=p["rotor"]["profile"][::-1]), "counter-clockwise"),
    (lambda p: p["rotor"]["to_world"][0].__setitem__(0, 3.0), "rigid"),
    (lambda p: p["strips"][0].update(radii=[0.1]), "radii"),
    (lambda p: p["strips"][0].update(flank=99), "flank"),
    (lambda p: p["tool"].update(kind="drill"), "tool.kind"),
    (lambda p: p.update(target_flanks=[40]), "target_flanks"),
    (lambda p: p["rotor"].update(v0=True), "rotor.v0"),
    (lambda p: p.update(method=17), "method"),
    (lambda p: p["rotor"].update(outer_radius="big"), "outer_radius"),
    (lambda p: p.update(tool="cone"), "tool must be an object"),
    (lambda p: p.update(summary=[]), "summary must be an object"),
    (lambda p: p["strips"][0].update(flank=True), "flank"),
    (lambda p: p["rotor"].update(flanks=[[0, "a"]]), "rotor.flanks"),
    (lambda p: p["tool"].update(alpha=0.03, r1c=-0.05, r2c=0.1), "tool must have 0 < alpha < pi/2 and 0 <= r1c"),
    (lambda p: p["tool"].update(h=float("nan")), r"tool.h must be a finite number > 0, got nan"),
    (lambda p: p["tool"].update(shank_length=float("inf")), r"tool.shank_length must be a finite number >= 0"),
    (lambda p: p["tool"].update(r1=-0.1), r"tool.r1 must be a finite number >= 0, got -0.1"),
    (lambda p: p["tool"].update(length="long"), r"tool.length must be a finite number > 0, got 'long'"),
    (lambda p: p["strips"][0].update(axis_end=p["strips"][0]["axis_start"]),
     r"strips\[0\]: axis_start and axis_end coincide, yet the tool's radius varies"),
    (lambda p: p["summary"].update(max_error=-0.001), r"summary.max_error -0.001 is below summary.min_error -0.0005"),
    (lambda p: p.update(tolerance=float("nan")), r"tolerance must be a finite number > 0 and at most "
                                                 r"rotor.outer_radius 1.0 \(in the plan's length unit\), got nan"),
    (lambda p: p.update(tolerance=2.0), r"tolerance must be .* at most rotor.outer_radius 1.0 .*, got 2.0"),
    (lambda p: p["strips"][0].update(radii=["0.05", 0.08]), r"strips\[0\].radii must hold numbers only, got '0.05'"),
    (lambda p: p["strips"][0].update(axis_start=["0", 0, 0]), r"strips\[0\].axis_start must hold numbers only"),
    (lambda p: p["rotor"]["profile"][3].__setitem__(0, None), r"rotor.profile must hold numbers only, got None"),
    (lambda p: p["rotor"].update(profile=p["rotor"]["profile"][:719] + [[0.5]]), r"rotor.profile must hold numbers "
                                                                                r"in lists of equal lengths"),
    (lambda p: p["strips"][0].update(shank_radius=-0.02), r"strips\[0\].shank_radius must be >= 0 \(0: no shank\), "
                                                          r"got -0.02"),
    (lambda p: p["strips"][0].update(reported_max_error=-1.0), r"strips\[0\].reported_max_error -1.0 is below"),
    (lambda p: p["rotor"].update(outer_radius=2.0), r"rotor.outer_radius 2.0 is not the profile's largest radius 1 "),
    (lambda p: p["tool"].update(engagement=1.5), r"tool.engagement must be at most 1, got 1.5"),
    (lambda p: p["rotor"].update(extent={"z_range": [0.0, 1e300], "shafts": []}), r"rotor.extent reaches 1e\+300"),
    (lambda p: p["tool"].update(alpha=None, r1c=0.05, r2c=0.08), r"tool gives r1c, r2c but not all of alpha, r1c and "
                                                                r"r2c"),
    (lambda p: p.update(tolerance=0), r"tolerance must be a finite number > 0 .*, got 0"),
    (lambda p: p["rotor"].update(v0=1e-300), r"rotor.v0 1e-300 must be within 1e-06..1e\+06 times rotor.outer_radius"),
    (lambda p: p["strips"][0].update(axis_start=[1e300, 0.0, 0.0]), r"strips\[0\].axis_start .* is over 1e\+06 times"),
    (lambda p: p["strips"][0].update(radii=[0.0, 0.0]), r"strips\[0\].radii are all 0: a tool of no thickness"),
    (lambda p: p["strips"][0].update(radii=[1e-9, 1e-9]), r"strips\[0\]: the tool is .* times as long as its largest "
                                                          r"radius \(at most 1000\): a needle"),
    (lambda p: p["rotor"].update(profile=(np.asarray(p["rotor"]["profile"]) * 1e7).tolist()),
     r"rotor.profile reaches .*, over 1e\+06 times rotor.outer_radius"),
])
def test_plan_validation_names_the_field(mutate, message):
    plan = json.loads(json.dumps(sample_plan()))
    mutate(plan)
    with pytest.raises(PlanError, match=message):
        validate_plan(plan)


@pytest.mark.parametrize("argv", [
    ["plan", "double-flank", "--builtin", "asymmetric-female", "--valley", "0", "--out", "{missing}/df.json"],
    ["rotor", "--kind", "srm_a", "--part", "male", "--out", "{missing}/rotor.stl"],
    ["post", "{plan}", "--machine", "rotor-xa-b", "--post", "linuxcnc", "-o", "{missing}/p.ngc"],
])
def test_cli_output_into_a_missing_folder_fails_at_once(tmp_path, argv):
    """An output file whose folder does not exist is named before any planning, not after it (the write itself
    would fail later with the system's "No such file or directory")."""
    plan = tmp_path / "p.json"
    write_plan(plan, sample_plan())
    missing = tmp_path / "nowhere"
    args = [a.format(missing=missing, plan=plan) for a in argv]
    r = main_cli(*args)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.strip() == "error: --out {}: the folder {} does not exist".format(args[-1], missing)
    assert not missing.exists()


@pytest.mark.parametrize("argv", [
    ["plan", "double-flank", "--builtin", "asymmetric-female", "--valley", "0", "--out", "{folder}"],
    ["post", "{plan}", "--machine", "rotor-xa-b", "--post", "linuxcnc", "-o", "{folder}"],
])
def test_cli_output_that_is_a_folder_fails_at_once(tmp_path, argv):
    """An output path naming a folder is refused before any work (the write would fail at its end), the folder
    left as it was."""
    plan = tmp_path / "p.json"
    write_plan(plan, sample_plan())
    folder = tmp_path / "programs"
    folder.mkdir()
    args = [a.format(folder=folder, plan=plan) for a in argv]
    r = main_cli(*args)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.strip() == "error: --out {0}: {0} is a folder: give a file name".format(folder)
    assert list(folder.iterdir()) == []


@pytest.mark.parametrize("argv, message", [
    (["post", "{plan}", "--machine", "rotor-xa-b", "--post", "linuxcnc", "-o", "{plan}"],
     "--out {plan} is also the input {plan}"),
    (["export", "{plan}", "--cl", "{dot_plan}"], "--cl {dot_plan} is also the input {plan}"),
    (["analyze", "{mesh}", "--profile-out", "{mesh}"], "--profile-out {mesh} is also the input {mesh}"),
    (["plan", "double-flank", "--mesh", "{mesh}", "--out", "{mesh}"], "--out {mesh} is also --mesh {mesh}"),
    (["plan", "double-flank", "--builtin", "asymmetric-female", "--tool-csv", "{new}", "--out", "{new}"],
     "--out and --tool-csv name the same file {new}"),
    (["plan", "double-flank", "--builtin", "asymmetric-female", "--tool-csv", "{missing}/t.csv", "--out", "{new}"],
     "--tool-csv {missing}/t.csv: the folder {missing} does not exist"),
])
def test_cli_refuses_an_output_that_would_destroy_an_input(tmp_path, argv, message):
    """An output path naming an input file (or another output) is refused before any work, the file untouched."""
    plan = tmp_path / "p.json"
    write_plan(plan, sample_plan())
    mesh = tmp_path / "rotor.stl"
    mesh.write_bytes(b"solid x\nendsolid x\n")
    names = dict(plan=plan, dot_plan=tmp_path / "." / "p.json", mesh=mesh, new=tmp_path / "new.json",
                 missing=tmp_path / "nowhere")
    before = plan.read_bytes(), mesh.read_bytes()
    r = main_cli(*[a.format(**names) for a in argv])
    assert r.returncode == 2 and r.stderr.strip().startswith("error: " + message.format(**names)), r.stderr
    assert (plan.read_bytes(), mesh.read_bytes()) == before and not (tmp_path / "new.json").exists()


def test_cli_rotor_then_analyze_json(tmp_path):
    out = tmp_path / "rotor.stl"
    r = main_cli("rotor", "--kind", "srm_a", "--part", "male", "--scale", "50", "--resolution", "3000",
                 "--axial", "40", "--out", out)
    assert r.returncode == 0, r.stderr
    assert "srm_a-male" in r.stdout and out.stat().st_size > 0
    r = main_cli("analyze", out, "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    rotor = builtin_by_name("srm_a-male", scale=50)
    assert abs(d["v0"] / rotor.v0 - 1) < 1e-4
    assert d["handedness"] == "right" and d["flank_count"] == 8
    T = np.array(d["to_world"])
    assert T.shape == (4, 4) and np.allclose(T[:3, 2], d["axis_direction"])
    assert len(d["profile"]) >= 720 and d["residual"] < d["residual_threshold"]


def test_cli_formats_and_left_hand(tmp_path):
    for ext in ("ply", "obj"):
        out = tmp_path / f"r.{ext}"
        r = main_cli("rotor", "--kind", "nilson", "--part", "female", "--handedness", "right",
                     "--resolution", "1500", "--axial", "20", "--out", out)
        assert r.returncode == 0, r.stderr
        r = main_cli("analyze", out)
        assert r.returncode == 0, r.stderr
        assert "right-handed" in r.stdout and "12 flanks" in r.stdout


def test_cli_bad_input_is_one_clear_line(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("x,y\n0,0\n1,nan\n")
    r = main_cli("rotor", "--profile-csv", bad, "--lead", "3", "--length", "2", "--out", tmp_path / "x.stl")
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.startswith("error:") and "not a finite number" in r.stderr
    missing = main_cli("analyze", tmp_path / "none.stl")
    assert missing.returncode == 2 and "Traceback" not in missing.stderr
    assert "none.stl" in missing.stderr and "no such mesh file" in missing.stderr
    few = main_cli("analyze", tmp_path / "none.stl", "--profile-points", "100")
    assert few.returncode == 2 and "720" in few.stderr


def test_cli_profile_csv_rotor_round_trip(tmp_path):
    t = np.linspace(0, 2 * np.pi, 600, endpoint=False)
    rr = 20 + 4 * np.cos(3 * t)
    csv = tmp_path / "p.csv"
    np.savetxt(csv, np.c_[rr * np.cos(t), rr * np.sin(t)], delimiter=",", header="x,y", comments="")
    out = tmp_path / "r.stl"
    r = main_cli("rotor", "--profile-csv", csv, "--lead", "-90", "--length", "40", "--axial", "30", "--out", out)
    assert r.returncode == 0 and "left-handed" in r.stdout, r.stderr
    r = main_cli("rotor", "--profile-csv", csv, "--lead", "-90", "--handedness", "left", "--length", "40",
                 "--axial", "30", "--out", out)
    assert "right-handed" in r.stdout  # a negative lead flips the given hand, as for the built-ins
    r = main_cli("rotor", "--profile-csv", csv, "--lead", "-90", "--length", "40", "--axial", "30", "--out", out)
    assert r.returncode == 0, r.stderr
    d = json.loads(main_cli("analyze", out, "--json").stdout)
    assert d["handedness"] == "left" and abs(d["v0"] * 2 * np.pi / 90 - 1) < 1e-4 and d["lobes"] == 3


def test_cli_check_plan(tmp_path):
    path = tmp_path / "p.json"
    write_plan(path, sample_plan())
    r = run_cli("check-plan", path)
    assert r.returncode == 0 and "valid flank-plan/1" in r.stdout
    path.write_text("{not json")
    r = run_cli("check-plan", path)
    assert r.returncode == 2 and "not valid JSON" in r.stderr


def test_single_flank_plan_without_a_strip_says_why_and_writes_nothing(tmp_path):
    """A tool that fits nowhere on the flank (here one in mm on a built-in rotor in units of R) gets the planner's
    reasons and a hint at the units, exit 2, and the earlier file stays as it was."""
    out = tmp_path / "y.json"
    out.write_text("KEEP")
    r = main_cli("plan", "single-flank", "--builtin", "asymmetric-female", "--flank", "1", "--tool-r1", "2.5",
                 "--tool-r2", "4", "--tool-alpha", "0.1002", "--tolerance", "0.05", "--out", out)
    assert r.returncode == 2 and out.read_text() == "KEEP"
    assert r.stderr.startswith("error: no collision-free strip on flank 1: ") and "colliding" in r.stderr
    assert "the tool's smallest radius 2.5 exceeds the rotor's outer radius 1 R" in r.stderr


@pytest.mark.parametrize("argv, option", [
    (["plan", "single-flank", "--builtin", "asymmetric-female", "--flank-point", "1000,1000,1000", "--tool-r1",
      "0.05", "--tool-r2", "0.08", "--tool-h", "0.3", "--tolerance", "2e-3"], "--flank-point 1000,1000,1000"),
    (["plan", "double-flank", "--builtin", "asymmetric-female", "--valley-point", "0,0,0"], "--valley-point 0,0,0"),
])
def test_a_picked_point_far_from_the_rotor_is_refused(tmp_path, argv, option):
    """A flank or valley point in another unit or frame is named with its distance and the limit instead of
    silently picking the flank nearest to it (the axis point 0,0,0 lies at the root radius from every flank)."""
    r = main_cli(*argv, "--out", tmp_path / "p.json")
    assert r.returncode == 2 and r.stderr.startswith(f"error: {option} lies ")
    assert "from the rotor surface, above the limit 0.5 R (0.5 of the outer radius)" in r.stderr
    assert not (tmp_path / "p.json").exists()


@pytest.mark.parametrize("argv, message", [
    (["post", "{plan}", "--machine", "rotor-xa-b", "--post", "linuxcnc", "--vc", "0", "-o", "{tmp}/p.ngc"],
     "argument --vc: 0 is not a finite number > 0"),
    (["post", "{plan}", "--machine", "rotor-xa-b", "--post", "linuxcnc", "--outer-radius-mm", "nan", "-o",
      "{tmp}/p.ngc"], "argument --outer-radius-mm: nan is not a finite number > 0"),
    (["rotor", "--kind", "srm_a", "--part", "male", "--resolution", "3", "--out", "{tmp}/r.stl"],
     "argument --resolution: 3 is outside the limits 8..65536"),
    (["rotor", "--kind", "srm_a", "--part", "male", "--resolution", "100000000", "--out", "{tmp}/r.stl"],
     "argument --resolution: 100000000 is outside the limits 8..65536"),
    (["rotor", "--kind", "srm_a", "--part", "male", "--axial", "100000000", "--out", "{tmp}/r.stl"],
     "argument --axial: 100000000 is outside the limits 1..20000"),
    (["analyze", "{plan}", "--profile-points", "100000000"], "--profile-points 100000000 is over the maximum 65536"),
    (["cutter", "--builtin", "nilson-male", "--scale", "100", "--center-distance", "180", "--swivel", "20",
      "--lead", "1e-3", "--out", "{tmp}/c.csv"],
     "--lead 0.001 is below 0.1 times the rotor's outer radius 100: a screw rotor's lead is some times its radius"),
    (["plan", "single-flank", "--builtin", "asymmetric-female", "--flank", "0", "--tool-r1", "1e-12", "--tool-r2", "0.08",
      "--tool-h", "0.3", "--tolerance", "2e-3", "--out", "{tmp}/p.json"],
     "cone tool: tip radius r1 = 1e-12 is under a millionth of r2 = 0.08: give 0 for a sharp tip"),
    (["plan", "single-flank", "--builtin", "asymmetric-female", "--flank", "0", "--tool-r1", "0.05", "--tool-r2", "0.08",
      "--tool-h", "1e300", "--tolerance", "2e-3", "--out", "{tmp}/p.json"],
     "the tool (1e+300 long or wide) is over 100 times the rotor's outer radius 1: are they in the same unit?"),
    (["paraboloid", "--radius", "20", "--a", "-0.05", "--b", "7.2", "--pitch", "20", "--points", "100000000", "--out",
      "{tmp}/g.csv"], "--points 100000000 is over the maximum 100000"),
    (["plan", "single-flank", "--builtin", "asymmetric-female", "--flank", "0", "--tools", "auto", "--max-tools", "0",
      "--out", "{tmp}/p.json"], "argument --max-tools: 0 is outside the limits 1..50"),
    (["verify", "{binary}"], "{binary}: not a text file (a flank-plan is JSON text"),
    (["post", "{plan}", "--machine", "{binary}", "--post", "linuxcnc", "-o", "{tmp}/p.ngc"],
     "{binary}: not a text file (a machine file is JSON text)"),
    (["rotor", "--profile-csv", "{binary}", "--lead", "1", "--length", "1", "--out", "{tmp}/r.stl"],
     "{binary}: not a text file (a profile is CSV text of x,y rows)"),
    (["verify", "{plan}", "--tolerance", "-1e-3"], "tolerance -0.001 must be a finite number > 0"),
])
def test_cli_names_the_option_or_file_of_a_bad_value(tmp_path, argv, message):
    plan = tmp_path / "p.json"
    write_plan(plan, sample_plan())
    binary = tmp_path / "mesh.stl"
    binary.write_bytes(bytes(range(256)) * 4)
    names = dict(plan=plan, binary=binary, tmp=tmp_path)
    r = main_cli(*[a.format(**names) for a in argv])
    assert r.returncode == 2 and r.stderr.startswith("error: " + message.format(**names)), r.stderr


@pytest.mark.parametrize("argv, message", [
    (["double-flank", "--valley", "0", "--tool-r1", "nan"],
     "--tool-r1 does not apply to plan double-flank (it is an option of plan single-flank and freeform)"),
    (["double-flank", "--valley", "0", "--tolerance", "0"],
     "--tolerance does not apply to plan double-flank (it is an option of plan single-flank)"),
    (["single-flank", "--flank", "1", "--valley", "3", "--tool-r1", "0.05", "--tool-r2", "0.08", "--tool-h", "0.3"],
     "--valley does not apply to plan single-flank (it is an option of plan double-flank)"),
])
def test_an_option_of_another_planner_is_refused(tmp_path, argv, message):
    """An option the chosen planner does not read would be silently ignored: it is named instead."""
    r = main_cli("plan", argv[0], "--builtin", "asymmetric-female", *argv[1:], "--out", tmp_path / "p.json")
    assert r.returncode == 2 and r.stderr.strip() == "error: " + message


def test_a_plan_nested_too_deeply_is_named(tmp_path):
    """JSON nested 100,000 lists deep: the parser's recursion is refused by name (exit 2), not a traceback."""
    path = tmp_path / "deep.json"
    path.write_text("[" * 100000 + "]" * 100000)
    r = main_cli("check-plan", path)
    assert r.returncode == 2 and f"{path}: its JSON nests too deeply to be a plan" in r.stderr


def test_a_disc_cutter_plan_that_cannot_be_made_leaves_no_file(tmp_path):
    """cutter --plan-out makes and checks the plan before it writes either file: a lead no rotor has is refused
    by name (it used to write the CSV, then fail on the plan's rotor.v0), and neither file is left."""
    csv, plan = tmp_path / "c.csv", tmp_path / "p.json"
    r = main_cli("cutter", "--builtin", "nilson-male", "--scale", "100", "--center-distance", "180", "--swivel", "20",
                 "--lead", "1e9", "--out", csv, "--plan-out", plan)
    assert r.returncode == 2 and "--lead 1e+09 is over 6.283e+06 times the rotor's outer radius" in r.stderr
    assert sorted(tmp_path.iterdir()) == []


def test_export_options_that_would_change_nothing_are_refused(tmp_path):
    """--strip, --steps and --z-range do not shape --error-csv (the whole plan's verified profile), --steps not a
    free-form plan's exports, and strip meshes take at most 2000 steps: each is refused by name (they used to be
    ignored, or capped, without a word), and nothing is written."""
    from flank_addon.geometry.freeform_surfaces import plane_patch
    from flank_addon.methods.freeform_g1.planner import plan_freeform

    rotor = tmp_path / "rotor.json"
    write_plan(rotor, sample_plan())
    free = tmp_path / "free.json"
    S = plane_patch(size=1.0, resolution=12)
    write_plan(free, plan_freeform(S.vertices, S.faces, direction=[1, 0, 0], r1=0.02, r2=0.06, L=0.2, n_columns=5,
                                   n_ruling_samples=5))
    for argv, words in (((rotor, "--error-csv", tmp_path / "e.csv", "--strip", "0", "--steps", "9"),
                         "--strip, --steps apply to --cl and the strip meshes: --error-csv writes"),
                        ((free, "--cl", tmp_path / "f.apt", "--steps", "10"), "--steps applies to rotor plans"),
                        ((rotor, "--strips-stl", tmp_path / "s", "--steps", "5000"),
                         "--steps 5000 is over 2000 for strip meshes")):
        r = main_cli("export", *argv)
        assert r.returncode == 2 and words in r.stderr, r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["free.json", "rotor.json"]
    # a plan file an editor saved with a byte-order mark reads as the plan
    bom = tmp_path / "bom.json"
    bom.write_bytes(b"\xef\xbb\xbf" + rotor.read_bytes())
    assert main_cli("check-plan", bom).returncode == 0
