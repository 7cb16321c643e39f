"""Runs of equal sorted keys, vectorised: where each run starts, its least value and the first position of it,
and the rank of every element within its run.

Many searches here keep a ragged set of candidates per row as flat arrays with a sorted row key (the time samples
of a helix, the centres in a point's ball, the pieces of a split segment); these are the operations on them that
a Python loop over the rows would otherwise do.
"""
import numpy as np


def run_starts(keys):
    """Indices where runs of equal sorted keys start."""
    if not len(keys):
        return np.zeros(0, int)
    out = np.flatnonzero(keys[1:] != keys[:-1])
    out += 1
    return np.concatenate(([0], out))


def segment_min(values, keys, n):
    """out[k] = min(values[keys == k]) for sorted integer keys (n,), +inf where a key has no value (NaN where one
    of its values is NaN)."""
    out = np.full(n, np.inf)
    if len(values):
        starts = run_starts(keys)
        out[keys[starts]] = np.minimum.reduceat(values, starts)
    return out


def segment_argmin(values, keys, n):
    """pos[k]: the position in ``values`` of key k's least value, as ``np.argmin`` over that key's values picks it
    (the first of equal values; the first NaN where there is one), for sorted integer keys (n,); -1 where a key
    has no value."""
    pos = np.full(n, -1)
    if len(values):
        m = segment_min(values, keys, n)[keys]
        hit = np.flatnonzero((values == m) | (np.isnan(values) & np.isnan(m)))
        first = hit[np.diff(keys[hit], prepend=-1) != 0]          # in position order: the first of each key
        pos[keys[first]] = first
    return pos


def ranks_in_runs(counts):
    """0, 1, .., counts[0] - 1, 0, 1, .., counts[1] - 1, ...: each element's rank within its run, for runs of
    ``counts`` consecutive elements (what ``np.repeat(..., counts)`` lays out)."""
    counts = np.asarray(counts)
    return np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
