"""Reading long JSON in pieces (flank_addon/io/json_pieces.py): the value ``json.loads`` gives, bit for bit and
type for type, with no call of the C scanner longer than a piece (plus one element), on plan-shaped documents in
every layout the product writes and on JSON built to mislead the cuts."""
import json
import math

import numpy as np
import pytest

from flank_addon import collector
from flank_addon.io import json_pieces
from flank_addon.io.json_pieces import loads_in_pieces
from flank_addon.io.plan import plan_text


def _same(a, b):
    """Equal as json.loads' results are: the same types, dict key order, float bits (-0.0, nan) and values."""
    if type(a) is not type(b):
        return False
    if isinstance(a, dict):
        return list(a) == list(b) and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, float):
        return (math.isnan(a) and math.isnan(b)) or (a == b and math.copysign(1, a) == math.copysign(1, b))
    return a == b


def _plan_like(n_vertices=3000, n_strips=7, seed=3):
    """A free-form plan's shape: a surface of [x, y, z] rows and [i, j, k] faces, strips with rulings (pairs of
    points), nested tool dicts, strings that hold brackets and commas, and every kind of JSON scalar."""
    rng = np.random.default_rng(seed)
    V = rng.normal(size=(n_vertices, 3)) * 10.0 ** rng.integers(-8, 8, size=(n_vertices, 1))
    V[0, 0], V[1, 1] = -0.0, 1e-320                       # a negative zero and a subnormal
    F = rng.integers(0, n_vertices, size=(2 * n_vertices, 3))
    strips = []
    for k in range(n_strips):
        strips.append({"rulings": rng.normal(size=(40 + 9 * k, 2, 3)).tolist(), "radii": [0.01, 0.03],
                       "tool": {"kind": "cone", "r1": 0.01, "note": "a }, { and ], [ in a string"},
                       "shafts": [{"z_range": [0, 1], "radius": 2.5}, {"z_range": [3, 4], "radius": 2}],
                       "collision": bool(k % 2), "kink_to_next_deg": None if k == n_strips - 1 else 0.25 * k,
                       "label": "strip \"{}\" \\ \u00e9\u4e2d \ud83d\ude00".format(k), "big": 2 ** 70 + k})
    return {"schema": "flank-plan/1", "method": "freeform-g1-cone", "length_unit": "mm",
            "surface": {"kind": "mesh", "vertices": V.tolist(), "faces": F.tolist()},
            "tool": {"kind": "cone", "r1": 0.01, "r2": 0.03}, "strips": strips, "empty": [], "nothing": {},
            "nested": [[[1, [2, [3, []]]], {"a": [{}]}]] * 50,
            "summary": {"max_error": 1.5e-5, "min_error": -2e-6, "elapsed_s": 2.2}}


LAYOUTS = {
    "stored on a run (json.dumps)": json.dumps,
    "plan file (plan_text)": plan_text,
    "indented": lambda d: json.dumps(d, indent=2),
    "compact": lambda d: json.dumps(d, separators=(",", ":")),
    "not ascii": lambda d: json.dumps(d, ensure_ascii=False),
}


@pytest.mark.parametrize("layout", list(LAYOUTS))
@pytest.mark.parametrize("piece", [64, 700, 5000, json_pieces.PIECE])
def test_same_value_as_json_loads_in_bounded_calls(monkeypatch, layout, piece):
    text = LAYOUTS[layout](_plan_like())
    want = json.loads(text)
    consumed = []
    real = json_pieces._DECODER

    class Counting:
        def raw_decode(self, s, idx=0):
            value, end = real.raw_decode(s, idx)
            consumed.append(end - idx)
            return value, end

        def decode(self, s):
            consumed.append(len(s))
            return real.decode(s)

    monkeypatch.setattr(json_pieces, "_DECODER", Counting())
    got = loads_in_pieces(text, piece=max(piece, 64))
    assert _same(got, want)
    if piece < len(text):
        # never the whole text at once; at most a piece plus the longest element that had to be read whole (a strip)
        longest_strip = max(len(json.dumps(s)) for s in want["strips"]) * 2
        assert len(consumed) > 1 and max(consumed) <= max(piece, 64) + longest_strip, (max(consumed), len(text))
    if piece <= 5000:
        assert len(consumed) > len(text) / (piece + 2 * max(len(json.dumps(s)) for s in want["strips"]))


def test_short_text_is_one_call_and_scalars_and_top_level_arrays_read():
    assert loads_in_pieces('{"a": [1, 2.5, "x"]}') == {"a": [1, 2.5, "x"]}
    for doc in ([0.1 * k for k in range(20000)], [[k, -k] for k in range(5000)], "s" * 1000, 12345, None,
                [{"k": k} for k in range(3000)], [[[k]] for k in range(3000)]):
        text = json.dumps(doc)
        assert _same(loads_in_pieces(text, piece=256), json.loads(text)), type(doc)
    text = "  \n" + json.dumps([1.5] * 4000) + " \n\t"
    assert _same(loads_in_pieces(text, piece=128), json.loads(text))
    nan = loads_in_pieces(json.dumps([float("nan"), float("inf"), -float("inf")] * 400), piece=128)
    assert math.isnan(nan[0]) and nan[1] == math.inf and nan[2] == -math.inf and len(nan) == 1200


def test_cuts_that_do_not_fall_between_elements_are_not_taken():
    """Elements whose text repeats the cut inside them: rows of different depth, strings holding the
    separator, and elements longer than a piece."""
    irregular = [[k, [k, k + 1]] if k % 3 else [[k], k] for k in range(4000)]
    strings = ["], [" * (k % 5) + "]], [[" + '\\"' * (k % 3) for k in range(4000)]
    long_rows = [list(range(300 + k)) for k in range(60)]
    mixed = [{"a": [1, {"b": "}, {"}]}, [2, [3]], "]", 4.5, None] * 800
    for doc in (irregular, strings, long_rows, mixed, {"x": irregular, "y": {"z": strings, "w": long_rows}}):
        text = json.dumps(doc)
        assert _same(loads_in_pieces(text, piece=300), json.loads(text))


@pytest.mark.parametrize("bad", ['{"a": [1, 2, 3', '{"a": [1, 2,, 3]}', '[1, 2] x', '{"a" 1}', '[' + '1, ' * 3000,
                                 '[' + '0, ' * 3000 + ']', '{"faces": [' + '[0, 1, 2], ' * 3000 + ']}',
                                 '{' + '"k": 1, ' * 3000 + '}',
                                 '[' + '"x", ' * 3000 + '}', '{"a": [' + '[1, 2], ' * 3000 + '[3, 4]}'])
def test_invalid_json_raises_json_loads_error(bad):
    with pytest.raises(json.JSONDecodeError) as want:
        json.loads(bad)
    with pytest.raises(json.JSONDecodeError) as got:
        loads_in_pieces(bad, piece=100)
    assert str(got.value) == str(want.value)


def test_progress_reports_the_share_read_and_can_stop_the_reading():
    text = json.dumps(_plan_like())
    seen = []
    loads_in_pieces(text, piece=4096, progress=seen.append)
    assert len(seen) > 20 and all(0.0 <= f <= 1.0 for f in seen) and seen == sorted(seen) and seen[-1] > 0.9

    class Stop(Exception):
        pass

    def stop(fraction):
        if fraction > 0.5:
            raise Stop

    with pytest.raises(Stop):
        loads_in_pieces(text, piece=4096, progress=stop)
    with pytest.raises(TypeError, match="reads a str"):
        loads_in_pieces(text.encode())


def test_arrays_of_one_long_element_and_long_last_values():
    """A long array whose only element is longer than a piece (no comma follows it anywhere), and long values at
    the very end of the text."""
    for doc in ([[list(range(20000))]], {"a": [[list(range(20000))]]}, [list(range(20000))],
                {"a": 1, "z": [[0.5] * 20000]}, [{"k": list(range(20000))}]):
        text = json.dumps(doc)
        assert _same(loads_in_pieces(text, piece=256), json.loads(text)), str(doc)[:40]


def test_deep_nesting_reads_as_json_loads_does():
    """Nested deeper than the reader's own Python frames go: the value (or error) of json.loads."""
    for depth in (400, 900):
        text = "[" * depth + ", ".join(map(str, range(3000))) + "]" * depth
        assert loads_in_pieces(text, piece=256) == json.loads(text)


@pytest.mark.parametrize("name", ["first element alone", "first separator alone", "alternating", "irregular"])
def test_arrays_whose_cuts_miss_cost_a_few_readings_of_the_text(monkeypatch, name):
    """When the cut taken from one element does not fit the next ones, elements are read one at a time and the cut
    is taken again from them; the cuts that missed (their failed parses included) cost a few times the text."""
    doc_text = {"first element alone": json.dumps([[[0]]] + [[0]] * 20000),
                "first separator alone": "[0, " + ",".join(["0"] * 20000) + "]",
                "alternating": json.dumps([[k] if k % 2 else [[k]] for k in range(10000)]),
                "irregular": json.dumps([[k, [k]] if k % 3 else {"a": [k]} for k in range(6000)])}[name]
    scanned = []
    real = json_pieces._DECODER

    class Counting:
        def raw_decode(self, s, idx=0):
            try:
                value, end = real.raw_decode(s, idx)
            except json.JSONDecodeError as ex:
                scanned.append(ex.pos - idx)
                raise
            scanned.append(end - idx)
            return value, end

        def decode(self, s):
            scanned.append(len(s))
            return real.decode(s)

    searched = []

    class Text(str):                 # the searches for cuts: the characters each one went through
        def find(self, sub, start=0):
            at = str.find(self, sub, start)
            searched.append((at if at >= 0 else len(self)) - start)
            return at

    monkeypatch.setattr(json_pieces, "_DECODER", Counting())
    assert _same(loads_in_pieces(Text(doc_text), piece=512), json.loads(doc_text))
    assert sum(scanned) < 6 * len(doc_text), (sum(scanned), len(doc_text))
    assert sum(searched) < 6 * len(doc_text), (sum(searched), len(doc_text))


@pytest.mark.parametrize("items", [1, 7, 100, json_pieces.ITEMS])
def test_written_in_pieces_is_json_dumps_text(monkeypatch, items):
    """The same characters as json.dumps, with no call of the encoder on more than ``items`` list elements (or
    one member of an object, or one element of a list of objects)."""
    doc = _plan_like(n_vertices=5000)
    written = []
    real = json.dumps

    def counting(obj, *a, **kw):
        written.append(len(obj) if isinstance(obj, (list, tuple)) and len(obj) > 1 else 1)
        return real(obj, *a, **kw)

    monkeypatch.setattr(json_pieces.json, "dumps", counting)
    text = json_pieces.dumps_in_pieces(doc, items=items)
    monkeypatch.setattr(json_pieces.json, "dumps", real)
    assert text == json.dumps(doc)
    assert max(written) <= max(items, 50)      # 50: the "nested" field, a list of lists of lists read whole
    assert len(written) >= 15000 / items            # the 5,000 vertex and 10,000 face rows


def test_written_in_pieces_edge_cases():
    odd = {1: 2, "b": 3}                        # a key that is not a string: json.dumps writes "1"
    for doc in ([], {}, [[]], {"a": []}, odd, [odd] * 10, [{"x": 1}, 2, [3]], (1, 2), [(1, [2, 3])] * 9,
                {"k": (1, {"z": float("nan")})}, "s\u00e9", None, 3, [1.5] * 50, {"a": [[1, 2]] * 50, "b": {"c": [{}] * 3}},
                [{"d": [{"e": []}]}] * 20):
        assert json_pieces.dumps_in_pieces(doc, items=7) == json.dumps(doc), doc
    with pytest.raises(TypeError, match="not JSON serializable"):
        json_pieces.dumps_in_pieces({"a": [1] * 20 + [np.float32(1.0)]}, items=7)
    loop = []
    loop.append({"again": loop})
    with pytest.raises(ValueError, match="Circular reference"):
        json_pieces.dumps_in_pieces(loop, items=7)


def test_rows_to_tuples_are_tolist_rows():
    rng = np.random.default_rng(5)
    for a in (rng.normal(size=(1000, 3)), rng.integers(0, 99, size=(1001, 3)), np.zeros((0, 3)),
              np.array([[True, False]] * 300)):
        got, want = json_pieces.rows_to_tuples(a, rows=64), a.tolist()
        assert got == [tuple(r) for r in want] and json.dumps(got) == json.dumps(want)
        assert all(type(r) is tuple for r in got)
        if want:
            assert type(got[0][0]) is type(want[0][0])        # Python numbers, not numpy scalars


def test_lists_to_array_converts_as_asarray_does():
    rows_int, rows_mixed = [[k, k + 1, k + 2] for k in range(100)], [[1, 2, 3]] * 50 + [[1.5, 2, 3]] * 50
    for rows, dtype in ((rows_int, None), (rows_int, float), (rows_mixed, None), (rows_int, np.int64),
                        ([[True, 2, 3]] * 100, None), ([[2 ** 70, 1, 2]] * 100, None), ([], float),
                        ([[8, 8, 8]] * 2 + [[2, 3, 1.5]] + [[9, 3, -2 ** 63 - 1]], None),
                        ([["a", "bb", "c"]] * 3 + [["long text", "x", "y"]] * 3, None)):
        got, want = json_pieces.lists_to_array(rows, dtype, slice_rows=2), np.asarray(rows, dtype)
        assert got.dtype == want.dtype and got.shape == want.shape and (got == want).all()
        assert [type(x) for x in got.ravel()[:12]] == [type(x) for x in want.ravel()[:12]]
    for bad in ([[1, 2, 3]] * 5 + [[1, 2]] * 5, [[1, 2, 3]] * 3 + [[1, 2]], [[10 ** 400, 1, 2]] + [[1, 2]] * 9,
                [[{}, 0, 0]] + [[0.0, 0, 0]] * 20 + [[0, 0]]):
        with pytest.raises(ValueError) as got:
            json_pieces.lists_to_array(bad, float, slice_rows=2)
        with pytest.raises(ValueError) as want:
            np.asarray(bad, float)
        assert str(got.value) == str(want.value)


def test_a_kept_plans_surface_rows_are_tuples_and_its_text_is_the_same():
    import gc

    from flank_addon.io.plan import rows_as_tuples

    doc = _plan_like(n_vertices=4000)
    text = json.dumps(doc)
    kept = rows_as_tuples(json.loads(text), slice_rows=300)
    assert json.dumps(kept) == text
    assert all(type(r) is tuple for r in kept["surface"]["vertices"] + kept["surface"]["faces"])
    assert kept["surface"]["vertices"] == [tuple(r) for r in doc["surface"]["vertices"]]
    gc.collect()
    assert not any(gc.is_tracked(r) for r in kept["surface"]["faces"][:100])   # no work for the collector
    assert rows_as_tuples({"rotor": {}}) == {"rotor": {}}


def test_collector_paused_by_overlapping_blocks_comes_back_on():
    """Two workers reading at once: whatever order their blocks end in, the collector is on afterwards (and stays
    off if it was off before)."""
    import gc

    assert gc.isenabled()
    a, b = collector.collector_paused(), collector.collector_paused()
    a.__enter__()
    b.__enter__()
    assert not gc.isenabled()
    a.__exit__(None, None, None)
    assert not gc.isenabled()                   # b still reads
    b.__exit__(None, None, None)
    assert gc.isenabled()
    a, b = collector.collector_paused(), collector.collector_paused()
    a.__enter__()
    b.__enter__()
    b.__exit__(None, None, None)
    a.__exit__(None, None, None)
    assert gc.isenabled()
    gc.disable()
    try:
        with collector.collector_paused():
            pass
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_a_few_long_lists_are_written_in_pieces(monkeypatch):
    doc = {"curves": [[[k, 0.5, 1.0] for k in range(3000)], [[0.25] * 5000, [0.75] * 5000]]}
    written = []
    real = json.dumps

    def counting(obj, *a, **kw):
        written.append(len(obj) if isinstance(obj, (list, tuple)) else 1)
        return real(obj, *a, **kw)

    monkeypatch.setattr(json_pieces.json, "dumps", counting)
    text = json_pieces.dumps_in_pieces(doc, items=100)
    monkeypatch.setattr(json_pieces.json, "dumps", real)
    assert text == json.dumps(doc) and max(written) <= 100
