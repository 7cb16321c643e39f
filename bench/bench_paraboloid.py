"""Doğrusadık groove section: time per profile beside the paper's figure, and agreement with the sweep.

The paper reports 558 s to obtain the section in a CAD system (by superimposing the tool's
instantaneous sections).  The budget is 10 ms per profile.  The sweep simulation of part 1
(knowing only the lens and the helix) is run on the same section as the independent reference.

    .venv/bin/python bench/bench_paraboloid.py
"""
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

import numpy as np  # noqa: E402

from flank_addon.methods.paraboloid_groove.groove import groove_section  # noqa: E402
from flank_addon.simulation.sweep import ParaboloidPart, RevolvingTool, machined_deviation  # noqa: E402

PAPER_CAD_SECONDS = 558.0


def main():
    R, a, b, p = 20.0, -0.05, 7.2, 20.0
    for n in (401, 2001):
        groove_section(R, a, b, p, n=n)
        reps = 200
        t0 = time.perf_counter()
        for _ in range(reps):
            sec = groove_section(R, a, b, p, n=n)
        dt = (time.perf_counter() - t0) / reps
        print(f"analytic section, {n:5d} points: {dt * 1e3:7.3f} ms  (budget 10 ms; paper, CAD: "
              f"{PAPER_CAD_SECONDS:.0f} s -> {PAPER_CAD_SECONDS / dt:.1e}x)")
    print(f"x-axis intercepts: {sec.x[0]:.12g}, {sec.x[-1]:.12g} (paper: -32, -8); "
          f"max overcut vs the tool's own section: {sec.overcut.max():.4f} mm")
    sec = groove_section(R, a, b, p, n=401)
    dx, dy = np.gradient(sec.x), np.gradient(sec.y)
    nrm = np.c_[dy, -dx] / np.hypot(dx, dy)[:, None]
    pts = np.c_[sec.x, np.zeros_like(sec.x), sec.y]
    nrm3 = np.c_[nrm[:, 0], np.zeros_like(sec.x), nrm[:, 1]]
    tool = RevolvingTool([ParaboloidPart([-R, 0.0, 0.0], [0.0, 0.0, 1.0], a, b)])
    t0 = time.perf_counter()
    dev = machined_deviation([tool], pts, nrm3, p / (2 * np.pi), "right", max_deviation=1.0)
    dt = time.perf_counter() - t0
    print(f"sweep simulation of the same 401 points: {dt:.2f} s; "
          f"max |analytic - simulated| = {np.abs(dev).max() * 1e3:.2e} um (target: <= 0.1 um)")


if __name__ == "__main__":
    main()
