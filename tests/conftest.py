# SPDX-License-Identifier: GPL-3.0-or-later
"""Shared fixtures of the test suite and its distribution over pytest-xdist workers.

Fixtures: the built-in rotors the core tests plan on and their surfaces, made once per process (``builtin``,
``female``, ``asym_male``).

Distribution (``make test`` runs ``pytest -n auto --dist loadgroup``; the scheduler is
``pytest_xdist_make_scheduler`` below):

* Work units.  Tests that share a module-scoped fixture run on one worker, one after the other (a unit per
  connected set of such fixtures), so an expensive module fixture -- a plan, a Blender scenario run -- is
  computed once, not once per worker.  The same holds for the session fixtures of a sub-directory's conftest
  (e.g. tests/machining: one unit per directory), for the expensive session fixtures of this file
  (``_GROUPED_SESSION_FIXTURES``) and for an explicit ``@pytest.mark.xdist_group(name)``.  Every other test
  is a unit of its own; the cheap session fixtures of this file are made on every worker, the extension zip
  (tests/blender/conftest.py) once per run behind a file lock.  The workers compute the units while they
  collect and leave them in the run's temporary directory for the controller (pytest-xdist 3.8 cannot put
  its group names into pytest 9's node ids, so its own loadgroup would split them).
* Order.  Units start longest first (longest-processing-time rule): a test's expected seconds come from
  the durations recorded by earlier runs in .pytest_cache (``flank/durations``), else from
  ``EXPECTED_SECONDS`` below (a clean clone), else ``DEFAULT_SECONDS``; only the second unit is the longest of
  the other kind (Blender or core), so that the second worker does not wait while the first builds and
  installs the extension; and while LinuxCNC's interpreter installs in the background
  (tests/linuxcnc_install.py), the machining units start only after about ``INSTALL_HEAD_START`` seconds of
  other work.  Each worker holds the test it runs and at most one more, so a long unit never waits behind
  another worker's queue.

Without xdist (plain ``pytest path``, the compatibility venvs) none of this is active.
"""
import json
import os

# One BLAS thread per process: the test workers (and the Blender scenarios they start) already keep every core
# busy, and OpenBLAS threads on top of them only compete and spin (in a 2-worker run on 2 cores they cost ~15 %
# more CPU, mostly system time).  Set before numpy is first imported; the workers and subprocesses inherit it.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import pytest  # noqa: E402

from flank_addon.geometry.rotors import builtin_by_name  # noqa: E402

# the Blender tests that compare with the core run it in the test interpreter; the compatibility venvs
# (make test-compat) have no scipy on purpose, so that the extension's bundled scipy is what Blender imports
CORE_NEEDS_SCIPY = "comparing with the core needs scipy in the test interpreter (the bpy-only venvs have none)"

# ---------------------------------------------------------------------------------------------- fixtures


@pytest.fixture(scope="session")
def builtin():
    """``builtin(name) -> (rotor, surface)``: a built-in rotor of default size and its helical surface, made
    once per process, so the surface's lazy foot-point tables (~1.6 s) are built once too."""
    pytest.importorskip("scipy", reason=CORE_NEEDS_SCIPY)
    made = {}

    def get(name):
        if name not in made:
            r = builtin_by_name(name)
            made[name] = (r, r.surface())
        return made[name]

    return get


@pytest.fixture(scope="session")
def female(builtin):
    """The built-in asymmetric female rotor and its helical surface."""
    return builtin("asymmetric-female")


@pytest.fixture(scope="session")
def asym_male(builtin):
    """The built-in asymmetric male rotor and its helical surface."""
    return builtin("asymmetric-male")


@pytest.fixture(scope="session")
def female_plan(female):
    """(rotor, result) of the single-flank plan of the asymmetric female's flank 1: cone asin(0.1), 0.05, 0.08 R
    with a shank 0.04 x 0.6 R, tolerance 1e-3 R, 18 seeds (the planner's defaults otherwise)."""
    import math

    from flank_addon.methods.single_flank.planner import plan_single_flank
    from flank_addon.tooling.cone import ConeTool

    r, s = female
    return r, plan_single_flank(s, r.flanks, 1, ConeTool(math.asin(0.1), 0.05, 0.08, 0.04, 0.6), 1e-3, n_seeds=18)


@pytest.fixture(scope="session")
def female_g1_plans(female):
    """(minimum cover, G1 cover) of the asymmetric female's flank 1: cone alpha = asin(0.1) to the 7 digits a
    Blender float property keeps (the operators plan with that typed value), 0.05, 0.08 R, shank 0.04 x 0.6 R, tolerance 2e-3 R, 12 seeds,
    4 rounds; the G1 run with at most 3 extra strips.  The G1 run is the slowest single-flank plan of the suite
    (about 13 s): the core test and the Blender operator test compare against this one."""
    import math

    from flank_addon.methods.single_flank.planner import plan_single_flank
    from flank_addon.tooling.cone import ConeTool

    r, s = female
    tool = ConeTool(float("{:.7g}".format(math.asin(0.1))), 0.05, 0.08, 0.04, 0.6)
    kw = dict(n_seeds=12, max_rounds=4)
    base = plan_single_flank(s, r.flanks, 1, tool, 2e-3, **kw)
    return base, plan_single_flank(s, r.flanks, 1, tool, 2e-3, g1=True, g1_extra_strips=3, **kw)


# ------------------------------------------------------------------------------------------ work units

# session fixtures of this file that are expensive: their users run on one worker
_GROUPED_SESSION_FIXTURES = {"female_plan", "female_g1_plans"}

# conftest files whose session fixtures are cheap or shared across workers by other means (no grouping)
_UNGROUPED_CONFTESTS = {"tests", "tests/blender"}


def _group_of(fixturedef, module):
    """Group key a fixture imposes on its users, or None."""
    scope = fixturedef.scope
    baseid = fixturedef.baseid or ""
    if scope == "module":
        return "{}::{}".format(module, fixturedef.argname)
    if fixturedef.argname in _GROUPED_SESSION_FIXTURES and baseid == "tests":
        return "tests/conftest.py::" + fixturedef.argname
    if scope in ("package", "session") and baseid.startswith("tests") and baseid not in _UNGROUPED_CONFTESTS \
            and "::" not in baseid and not baseid.endswith(".py"):
        return baseid                      # a sub-directory's conftest: one group per directory
    return None


GROUPS_FILE = "flank-xdist-groups.json"


def _groups(items):
    """{nodeid: group} for the tests that share an expensive fixture (connected sets of fixtures) or carry an
    explicit ``xdist_group`` mark; other tests are units of their own."""
    parent = {}

    def find(k):
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    keys_of = []
    for item in items:
        info = getattr(item, "_fixtureinfo", None)
        module = item.nodeid.split("::", 1)[0]
        keys = ["mark:" + str(m.args[0] if m.args else m.kwargs.get("name", "default"))
                for m in item.iter_markers("xdist_group")]
        for name in (info.names_closure if info is not None else ()):
            defs = info.name2fixturedefs.get(name)
            if defs:
                key = _group_of(defs[-1], module)
                if key is not None:
                    keys.append(key)
        for k in keys:
            parent.setdefault(k, k)
        for a, b in zip(keys, keys[1:]):
            parent[find(a)] = find(b)
        keys_of.append(keys)
    members = {}
    for keys in keys_of:
        if keys:
            members.setdefault(find(keys[0]), set()).update(keys)
    names = {root: "+".join(sorted(ks)) for root, ks in members.items()}
    return {item.nodeid: names[find(keys[0])] for item, keys in zip(items, keys_of) if keys}


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config, items):
    """On an xdist worker: write the work units for the controller's scheduler (pytest-xdist 3.8 cannot mark
    groups in pytest 9's node ids itself) into the run's shared temporary directory."""
    if not hasattr(config, "workerinput"):
        return
    path = config._tmp_path_factory.getbasetemp().parent / GROUPS_FILE
    part = path.with_name("{}.{}".format(path.name, config.workerinput["workerid"]))
    part.write_text(json.dumps(_groups(items), indent=0, sort_keys=True))
    os.replace(part, path)                  # every worker collects the same tests: the last write is as good


# ------------------------------------------------------------------------------------- expected seconds

DEFAULT_SECONDS = 0.3
CACHE_KEY = "flank/durations"
# seconds (setup + call + teardown) of the tests above 1 s, measured on the 2-core machine: what a clean clone
# (no .pytest_cache yet) orders its work by.  Rewrite it from a run's cache after large changes:
#     PYTHONPATH=. .venv/bin/python tests/conftest.py --write-expected
EXPECTED_FILE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "expected_seconds.json")


def _load_expected():
    try:
        with open(EXPECTED_FILE) as f:
            return {k: float(v) for k, v in json.load(f).items()}
    except (OSError, ValueError):
        return {}


EXPECTED_SECONDS = _load_expected()


def _test_id(nodeid):
    """nodeid without the '@group' suffix loadgroup appends."""
    at = nodeid.rfind("@")
    return nodeid[:at] if at > nodeid.rfind("]") else nodeid


class _DurationRecorder:
    """Sums setup + call + teardown seconds per test where the reports arrive (the controller under xdist,
    the only process without it) and merges them into the cache at the end of the session."""

    def __init__(self, config):
        self.config = config
        self.seconds = {}

    def pytest_runtest_logreport(self, report):
        tid = _test_id(report.nodeid)
        self.seconds[tid] = self.seconds.get(tid, 0.0) + float(getattr(report, "duration", 0.0) or 0.0)

    def pytest_sessionfinish(self, session):
        cache = getattr(self.config, "cache", None)
        if cache is None or not self.seconds:
            return
        known = dict(cache.get(CACHE_KEY, {}))
        known.update({k: round(v, 3) for k, v in self.seconds.items()})
        cache.set(CACHE_KEY, known)


def pytest_configure(config):
    if not hasattr(config, "workerinput"):      # not an xdist worker: the reports of every test arrive here
        config.pluginmanager.register(_DurationRecorder(config), "flank-duration-recorder")
        # byte-compile the planner once: the workers and the command-line tests' subprocesses then load the
        # cached bytecode even where the environment forbids writing it (PYTHONDONTWRITEBYTECODE), instead
        # of compiling the modules they import again in every process
        import compileall
        from pathlib import Path

        compileall.compile_dir(str(Path(__file__).resolve().parents[1] / "flank_addon"), quiet=1)
        if getattr(config.option, "numprocesses", None):
            # a parallel run on a fresh machine: LinuxCNC's interpreter installs while the other tests run
            import tempfile

            from linuxcnc_install import start_background_install
            start_background_install(tempfile.mkdtemp(prefix="flank-rs274-"))


def _expected_seconds(config):
    cache = getattr(config, "cache", None)
    recorded = cache.get(CACHE_KEY, {}) if cache is not None else {}
    return lambda tid: recorded.get(tid, EXPECTED_SECONDS.get(tid, DEFAULT_SECONDS))


# ------------------------------------------------------------------------------------------- scheduler

def _blender_unit(nodeids):
    """Does a work unit run Blender (needs the extension zip and its installed template)?"""
    return any(n.startswith("tests/blender/") for n in nodeids)


# expected seconds of work (both workers) that run before the machining units while LinuxCNC installs
INSTALL_HEAD_START = 150.0


def _after_the_install(units, unit_seconds):
    """The machining units (they read posted programs back with LinuxCNC's ``rs274``) moved behind about
    INSTALL_HEAD_START seconds of other work while its background install is going, so that no worker sleeps
    waiting for it (on a fresh machine the install takes about half a minute; the longest-first order would
    start them within seconds)."""
    from linuxcnc_install import background_pending

    if not background_pending():
        return units
    is_machining = [any(n.startswith("tests/machining/") for n in ids) for _, ids in units]
    machining = [u for u, m in zip(units, is_machining) if m]
    rest = [u for u, m in zip(units, is_machining) if not m]
    at, done = len(rest), 0.0
    for j, u in enumerate(rest):
        if done >= INSTALL_HEAD_START:
            at = j
            break
        done += unit_seconds(u[1])
    return rest[:at] + machining + rest[at:]


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """``--dist loadgroup``: the work units of :func:`_groups`, longest first, each worker holding at most one
    test beyond the one it runs."""
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadScopeScheduling

    seconds = _expected_seconds(config)
    groups_path = config._tmp_path_factory.getbasetemp() / GROUPS_FILE

    class LongestFirstScheduling(LoadScopeScheduling):
        _groups = None

        def _split_scope(self, nodeid):
            if self._groups is None:        # first call: every worker has finished collecting
                try:
                    self._groups = json.loads(groups_path.read_text())
                except (OSError, ValueError):
                    self._groups = {}       # no groups: every test a unit of its own
            tid = _test_id(nodeid)
            group = self._groups.get(tid)
            return "group " + group if group is not None else tid

        _ordered = False

        def _assign_work_unit(self, node):
            if not self._ordered:           # the first assignment: the queue is complete, order it once
                def unit_seconds(ids):
                    return sum(seconds(_test_id(n)) for n in ids)

                units = sorted(self.workqueue.items(), key=lambda kv: -unit_seconds(kv[1]))
                # the second worker starts on the longest unit of the other kind: the first Blender test of a
                # run builds the extension and installs it (~10 s behind a lock), a second Blender test
                # would only wait for it
                other = next((j for j, (_, ids) in enumerate(units)
                              if _blender_unit(ids) != _blender_unit(units[0][1])), None)
                if other is not None:
                    units.insert(1, units.pop(other))
                units = _after_the_install(units, unit_seconds)
                self.workqueue.clear()
                self.workqueue.update(units)
                self._ordered = True
            super()._assign_work_unit(node)

        def _reschedule(self, node):
            if node.shutting_down:
                return
            if not self.workqueue:
                node.shutdown()
                return
            # a worker runs a test once it knows the next one: the running test plus one queued suffices
            if self._pending_of(self.assigned_work[node]) >= 2:
                return
            self._assign_work_unit(node)

    return LongestFirstScheduling(config, log)


if __name__ == "__main__":                 # PYTHONPATH=. .venv/bin/python tests/conftest.py --write-expected
    import sys

    if sys.argv[1:] != ["--write-expected"]:
        sys.exit("usage: python tests/conftest.py --write-expected")
    cache = os.path.join(os.path.dirname(EXPECTED_FILE), os.pardir, ".pytest_cache", "v", *CACHE_KEY.split("/"))
    with open(cache) as f:
        seconds = json.load(f)
    kept = {k: round(v, 1) for k, v in sorted(seconds.items()) if v >= 1.0}
    part = EXPECTED_FILE + ".part"
    with open(part, "w") as f:
        json.dump(kept, f, indent=0, sort_keys=True)
        f.write("\n")
    os.replace(part, EXPECTED_FILE)
    print("{}: {} tests of {} above 1 s".format(EXPECTED_FILE, len(kept), len(seconds)))
