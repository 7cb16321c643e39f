"""The run helpers against a loop over the rows (np.argmin / np.min per row)."""
import numpy as np

from flank_addon.geometry.runs import ranks_in_runs, run_starts, segment_argmin, segment_min


def test_segment_min_and_argmin_are_those_of_each_row():
    rng = np.random.default_rng(4)
    counts = rng.integers(0, 6, 400)                     # rows without values too
    keys = np.repeat(np.arange(len(counts)), counts)
    values = rng.integers(0, 4, len(keys)).astype(float)   # many ties
    values[rng.random(len(keys)) < 0.03] = np.nan
    values[rng.random(len(keys)) < 0.03] = np.inf
    least, pos = segment_min(values, keys, len(counts)), segment_argmin(values, keys, len(counts))
    for k in range(len(counts)):
        mine = np.flatnonzero(keys == k)
        if not len(mine):
            assert least[k] == np.inf and pos[k] == -1
            continue
        assert pos[k] == mine[np.argmin(values[mine])]
        assert np.array_equal(least[k], np.min(values[mine]), equal_nan=True)


def test_run_starts_and_ranks():
    counts = np.array([3, 0, 1, 0, 0, 4, 2])
    assert ranks_in_runs(counts).tolist() == [0, 1, 2, 0, 0, 1, 2, 3, 0, 1]
    assert ranks_in_runs(np.zeros(3, int)).tolist() == []
    keys = np.repeat(np.arange(len(counts)), counts)
    assert run_starts(keys).tolist() == [0, 3, 4, 8]
    assert run_starts(np.zeros(0, int)).tolist() == []
