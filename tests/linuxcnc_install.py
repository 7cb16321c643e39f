"""LinuxCNC's interpreter ``rs274`` for the machining tests: installed with apt (package linuxcnc-uspace) where
it is missing.

On a fresh machine the install (apt-get update + the package) starts in the background when a parallel run
begins (:func:`start_background_install`, called by tests/conftest.py), so it overlaps with the CPU-bound tests
instead of holding a worker; the ``rs274`` fixture then waits for it (:func:`wait_or_install`) and installs in
the foreground only where no background install ran.  Only the package's dependencies are installed, not its
recommendations: with them apt installs about 400 packages instead of 92 (Qt, OpenCV, the documentation, even
a real-time kernel whose initramfs is built on the spot), two minutes of unpacking that competed with the tests
for the CPU, while ``rs274`` links only libraries of the dependencies.  The background install also runs at a
lower priority (``nice``)."""
import os
import shutil
import subprocess
import time

STATUS_ENV = "FLANK_RS274_INSTALL_STATUS"      # path of the background install's exit-status file
PACKAGE = "linuxcnc-uspace"
TIMEOUT_S = 1200


def _apt_prefix():
    """The command prefix that runs apt-get as root, or a reason why there is none."""
    if shutil.which("apt-get") is None:
        return None, "apt-get is not available"
    if os.geteuid() == 0:
        return [], None
    if shutil.which("sudo"):
        return ["sudo", "-n"], None
    return None, "not root and no sudo"


def _script(prefix):
    """Shell script: install the package; if that fails (stale lists), update the lists and try again."""
    apt = " ".join(prefix + ["apt-get"])
    install = f"{apt} install -y --no-install-recommends {PACKAGE}"
    return f"{install} || {{ {apt} update && {install}; }}"


def start_background_install(tmp_dir):
    """Start the install in the background where rs274 is missing; the status file's path goes into the
    environment that the test workers inherit.  Does nothing where rs274 exists or apt cannot run."""
    if shutil.which("rs274") is not None or os.environ.get(STATUS_ENV):
        return
    prefix, _ = _apt_prefix()
    if prefix is None:
        return
    os.makedirs(tmp_dir, exist_ok=True)
    status = os.path.join(tmp_dir, "rs274-install.status")
    log = os.path.join(tmp_dir, "rs274-install.log")
    script = "( {} ) > '{}' 2>&1; echo $? > '{}.part' && mv '{}.part' '{}'".format(
        _script(prefix), log, status, status, status)
    nice = ["nice", "-n", "10"] if shutil.which("nice") else []
    subprocess.Popen(nice + ["sh", "-c", script], env=dict(os.environ, DEBIAN_FRONTEND="noninteractive"),
                     stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                     start_new_session=True)
    os.environ[STATUS_ENV] = status


def background_pending():
    """Is a background install of this run still going?"""
    status = os.environ.get(STATUS_ENV)
    return bool(status) and not os.path.exists(status)


def _wait_for_background():
    """Wait for a background install of this run; its log tail if it failed, None if it succeeded or none ran."""
    status = os.environ.get(STATUS_ENV)
    if not status:
        return None
    deadline = time.monotonic() + TIMEOUT_S
    while not os.path.exists(status):
        if time.monotonic() > deadline:
            return f"the background install did not finish within {TIMEOUT_S} s"
        time.sleep(1.0)
    with open(status) as fh:
        code = fh.read().strip()
    if code == "0":
        return None
    try:
        with open(status[: -len(".status")] + ".log") as fh:
            return "exit status {}: {}".format(code, fh.read()[-3000:])
    except OSError:
        return f"exit status {code}"


def wait_or_install():
    """Make rs274 available: wait for this run's background install, else install now.  Returns None on
    success, else what went wrong (the end of apt's output)."""
    why = _wait_for_background()
    if shutil.which("rs274") is not None:
        return None
    prefix, reason = _apt_prefix()
    if prefix is None:
        return reason
    r = subprocess.run(["sh", "-c", _script(prefix)], capture_output=True, text=True, timeout=TIMEOUT_S,
                       env=dict(os.environ, DEBIAN_FRONTEND="noninteractive"))
    if r.returncode == 0 and shutil.which("rs274") is not None:
        return None
    return "; ".join(x for x in (why, (r.stdout + r.stderr)[-3000:]) if x)
