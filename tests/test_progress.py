"""Progress reports and cancellation of the planners (what the Blender Run operator relies on)."""
import math

import pytest

from flank_addon.tooling.cone import ConeTool
from flank_addon.methods.double_flank.planner import plan_double_flank
from flank_addon.methods.single_flank.planner import plan_single_flank
from flank_addon.progress import Cancelled, reporter, substage

TOOL = ConeTool(math.asin(0.1), 0.05, 0.08)


def test_reporter_maps_and_cancels():
    seen = []
    rep = reporter(lambda f, m: seen.append((f, m)), 0.2, 0.6)
    rep(0.5, "half")
    rep(2.0, "clamped")
    sub = substage(rep, 0.5, 1.0)
    sub(0.5, "sub")
    assert seen == [(pytest.approx(0.4), "half"), (pytest.approx(0.6), "clamped"), (pytest.approx(0.5), "sub")]
    reporter(None)(0.3, "no callback")             # a no-op
    with pytest.raises(Cancelled, match="stop here"):
        reporter(lambda f, m: False)(0.1, "stop here")


def _run(planner, female, progress):
    r, s = female
    if planner == "single":
        return plan_single_flank(s, r.flanks, 1, TOOL, 2e-3, n_seeds=6, max_rounds=2, check_collisions=False,
                                 progress=progress)
    return plan_double_flank(s, r.flanks, progress=progress)


@pytest.mark.parametrize("planner", ["single", "double"])
def test_progress_is_monotone_and_ends_done(planner, female):
    seen = []
    res = _run(planner, female, lambda f, m: seen.append((f, m)))
    fr = [f for f, _ in seen]
    assert len(seen) >= 4 and fr[0] == 0.0 and seen[-1] == (1.0, "done")
    assert all(0.0 <= a <= b <= 1.0 for a, b in zip(fr, fr[1:]))
    assert res.plan["strips"]


@pytest.mark.parametrize("planner", ["single", "double"])
def test_cancel_stops_the_run_without_a_result(planner, female):
    seen = []

    def stop_after_two(f, m):
        seen.append(f)
        return len(seen) < 2
    with pytest.raises(Cancelled):
        _run(planner, female, stop_after_two)
    assert len(seen) == 2                        # stopped at the second report, nothing after it
