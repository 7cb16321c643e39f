"""LinuxCNC's interpreter as the reference reader of rs274ngc programs (the canonical moves of ``rs274 -g``)."""
import re
import subprocess

import numpy as np
import pytest

CANON = re.compile(r"(STRAIGHT_FEED|STRAIGHT_TRAVERSE|SET_FEED_RATE)\(([^)]*)\)")


def run_rs274(rs274, path):
    """LinuxCNC's canonical moves of a program: [(kind, xyzabc (6,), feed)], or pytest.fail with its error."""
    r = subprocess.run([rs274, "-g", str(path)], capture_output=True, text=True, timeout=120)
    errors = [ln for ln in r.stderr.splitlines() if ln.strip() and ln.strip() != "executing"]
    if r.returncode != 0 or errors or "PROGRAM_END()" not in r.stdout:
        pytest.fail(f"rs274 could not read {path} (exit {r.returncode}): {' / '.join(errors)[:500]}")
    moves, feed = [], None
    for kind, args in CANON.findall(r.stdout):
        vals = [float(x) for x in args.split(",")]
        if kind == "SET_FEED_RATE":
            feed = vals[0]
        else:
            moves.append((kind, np.array(vals[:6]), feed))
    return moves


def rs274_times(moves):
    """(cutting, rapid-free) minutes of canonical moves the way LinuxCNC times feeds: XYZ distance over the
    feed, or the rotary distance when no linear axis moves."""
    cut, prev = 0.0, None
    for kind, pos, feed in moves:
        if prev is not None and kind == "STRAIGHT_FEED":
            d = pos - prev
            lin, rot = np.linalg.norm(d[:3]), np.linalg.norm(d[3:])
            cut += (lin if lin > 0 else rot) / feed
        prev = pos
    return cut
