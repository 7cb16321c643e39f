"""Reading and writing long JSON in pieces: the same value as ``json.loads`` and the same text as ``json.dumps``,
made by the json module's own C scanner and encoder, but never more than a piece in one call.

Why: the C scanner and encoder hold Python's interpreter lock for a whole call.  A free-form plan holds its
surface, and its text (11.7 MB for 200,000 triangles) takes about 0.3 s to parse and 0.4 s to write -- in a
worker thread, time in which Blender's interface runs no Python (no panel is drawn, no modal operator polls).
In pieces of a few milliseconds each, the interpreter switches threads between pieces, and a progress function
can report and cancel.

Writing (:func:`dumps_in_pieces`) is simple: an object with string keys is written member by member, a long
list (or tuple) ``ITEMS`` elements at a time, a list of objects or of a few long lists element by element, and
the pieces are joined with json.dumps' own separators.

How the pieces are cut.  A container whose text fits in ``piece`` characters is parsed in one call
(``raw_decode`` of a slice: a container is complete only with its closing bracket, so a parse that succeeds on
the slice is the parse of the whole text).  A longer object is read member by member; a longer array in runs
of elements: the text from the run's first element to a comma chosen about ``piece`` characters on is parsed
as ``"[" + run + "]"``.  That parse succeeds only if the comma separates two elements of this array (a cut
inside an element leaves a bracket or a string open), and if the array ends before the comma, the parse stops
at the array's own closing bracket -- so a success is always exactly the array's elements.  The commas tried
first are the ones that follow the closing brackets an element of this array ends with (``"]],"`` after
``[[x, y, z], [x, y, z]]``), which cut right for the regular arrays a plan holds; after a few misses the
elements are read one at a time.  Text that is not valid JSON is parsed again in one call, for
``json.loads``' own error.
"""
import json

import numpy as np

PIECE = 65_536              # characters per call: 1.5 ms of the C scanner on a plan's numbers (2.6 GHz EPYC)
ITEMS = 2048                # list elements per call of the encoder: 2-5 ms for rows of 3 floats
_CUTS_TRIED = 3             # cuts tried in a run before reading elements one at a time
_DECODER = json.JSONDecoder()
_WHITESPACE = " \t\n\r"


class _NotHere(Exception):
    """A cut that was not between two elements (internal: the next cut is tried)."""


def loads_in_pieces(text, piece=PIECE, progress=None):
    """``json.loads(text)`` for a str ``text``, parsed in calls of at most about ``piece`` characters (plus
    one element of an array, or one scalar, where that is longer).  ``progress(fraction)``, if given, is called
    between pieces with the share of the text read; it may raise to stop the reading (e.g. ``Cancelled``)."""
    if not isinstance(text, str):
        raise TypeError("loads_in_pieces reads a str, not {}".format(type(text).__name__))
    if len(text) <= piece:
        return _DECODER.decode(text)
    try:
        reader = _Reader(text, int(piece), progress)
        start = reader.skip(0)
        value, end = reader.value(start)
        if reader.skip(end) != len(text):
            raise _NotHere
    except (json.JSONDecodeError, _NotHere, IndexError, RecursionError):
        # not valid JSON, or nested deeper than this reader's Python frames go: json.loads' own message or value
        return _DECODER.decode(text)
    return value


def rows_to_tuples(a, rows=128):
    """The rows of a 2-D numpy array as a list of tuples of Python numbers (``[tuple(r) for r in a.tolist()]``),
    made ``rows`` rows at a time.  Tuples, because Python's garbage collector stops tracking a tuple of numbers
    but goes through every list at each full collection (a 200,000-triangle surface's 300,000 rows).  A few rows
    at a time, because one ``tolist`` call makes every object of the list while holding the interpreter lock
    (170 ms for 200,000 face rows in a planner's worker, Blender's interface waiting), and because lists that
    live through a few young collections age into the oldest generation and set off full collections: for a
    200,000-triangle surface's rows, 6 of them in slices of 16,384 rows, none in slices of 128.  ``json.dumps``
    writes a tuple as it writes a list."""
    a = np.asarray(a)
    out = []
    for i in range(0, len(a), rows):
        out.extend(map(tuple, a[i:i + rows].tolist()))
    return out


def lists_to_array(rows, dtype=None, slice_rows=16384):
    """``np.asarray(rows, dtype)`` of a long list of rows, converted a slice at a time: one conversion holds the
    interpreter lock while it runs (50-60 ms for the 200,000 face rows of a fine surface).  Where the slices do
    not all convert to one shape and type (rows of different lengths, ints and a float, objects), the whole list
    is converted at once: the same array, or numpy's own message."""
    if not isinstance(rows, list) or len(rows) <= slice_rows:
        return np.asarray(rows, dtype)
    try:
        parts = [np.asarray(rows[i:i + slice_rows], dtype) for i in range(0, len(rows), slice_rows)]
    except (ValueError, TypeError, OverflowError):
        parts = None
    if parts is None or len({(p.shape[1:], p.dtype) for p in parts}) != 1 or parts[0].dtype == object:
        return np.asarray(rows, dtype)      # slices that differ (or of objects): as the whole list converts
    return np.concatenate(parts)


def dumps_in_pieces(obj, items=ITEMS):
    """``json.dumps(obj)`` (its default settings), written in calls of at most ``items`` list elements (or one
    object member that is not a list or object)."""
    parts = []
    try:
        _write(obj, parts, max(int(items), 1))
    except RecursionError:
        return json.dumps(obj)            # nested too deep for this writer's frames: json.dumps' own result or error
    return "".join(parts)


def _write(obj, parts, items):
    if isinstance(obj, dict) and obj and all(isinstance(k, str) for k in obj):
        parts.append("{")
        for n, (key, value) in enumerate(obj.items()):
            parts.append(("{}: " if n == 0 else ", {}: ").format(json.dumps(key)))
            _write(value, parts, items)
        parts.append("}")
    elif isinstance(obj, (list, tuple)) and len(obj) > items:
        parts.append("[")
        for n in range(0, len(obj), items):
            if n:
                parts.append(", ")
            parts.append(json.dumps(obj[n:n + items])[1:-1])
        parts.append("]")
    elif isinstance(obj, (list, tuple)) and (any(isinstance(v, dict) for v in obj) or sum(
            len(v) for v in obj if isinstance(v, (list, tuple))) > 4 * items):    # a few long lists
        parts.append("[")
        for n, value in enumerate(obj):
            if n:
                parts.append(", ")
            _write(value, parts, items)
        parts.append("]")
    else:
        parts.append(json.dumps(obj))


class _Reader:
    def __init__(self, text, piece, progress):
        self.text, self.piece, self.progress = text, max(int(piece), 64), progress
        self.n = len(text)
        self.absent = {}                       # cut pattern -> where on it is not found in the text
        self.reported = 0

    def skip(self, i):
        text, n = self.text, self.n
        while i < n and text[i] in _WHITESPACE:
            i += 1
        return i

    def report(self, i):
        if self.progress is not None and i - self.reported >= self.piece:
            self.reported = i
            self.progress(i / self.n)

    def value(self, i):
        """(value, end) of the JSON value at ``i`` (no whitespace before it)."""
        text = self.text
        if text[i] not in "[{" or self.n - i <= self.piece:
            return _DECODER.raw_decode(text, i)
        try:                                   # a container that ends within one piece
            v, end = _DECODER.raw_decode(text[i:i + self.piece])
            return v, i + end
        except json.JSONDecodeError:
            pass
        self.report(i)
        return self.array(i) if text[i] == "[" else self.object(i)

    def object(self, i):
        text, out = self.text, {}
        j = self.skip(i + 1)
        if text[j] == "}":
            return out, j + 1
        while True:
            if text[j] != '"':
                raise _NotHere
            key, j = _DECODER.raw_decode(text, j)
            j = self.skip(j)
            if text[j] != ":":
                raise _NotHere
            out[key], j = self.value(self.skip(j + 1))
            j = self.skip(j)
            if text[j] == "}":
                return out, j + 1
            if text[j] != ",":
                raise _NotHere
            j = self.skip(j + 1)

    def array(self, i):
        text, out = self.text, []
        j = self.skip(i + 1)
        if text[j] == "]":
            return out, j + 1
        v, e = self.value(j)
        out.append(v)
        k, cut, alone_until = self.closers(j, e), None, 0
        while True:
            comma = self.skip(e)
            if text[comma] == "]":
                return out, comma + 1
            if text[comma] != ",":
                raise _NotHere
            j = self.skip(comma + 1)
            if text[j] == "]":                 # a trailing comma: not JSON (a run would read it as the end)
                raise _NotHere
            if cut is None:
                # what lies between the last element's closing brackets and the next one's opening bracket
                # (e.g. "]], [[" between [[x, y, z], [x, y, z]] and the next such pair), and where its comma is
                cut = (text[k:j] + (text[j] if text[j] in '[{"' else ""), comma - k)
            run = self.run(j, cut) if j >= alone_until else None
            if run is None:
                # no cut fitted: this element alone, and the cut taken from it; runs are tried again a piece on,
                # so that the cuts that missed cost at most a few times the text read alone
                v, e = self.value(j)
                out.append(v)
                self.report(e)
                if j >= alone_until:
                    alone_until = e + self.piece
                k, cut = self.closers(j, e), None
                continue
            values, e, closed = run
            out.extend(values)
            self.report(e)
            if closed:
                return out, e

    def closers(self, j, e):
        """Where the closing brackets of the element text[j:e] start."""
        while e > j and self.text[e - 1] in "]}":
            e -= 1
        return e

    def run(self, j, cut):
        """Elements from ``j`` on, about a piece of them: (values, end, closed) -- ``closed`` when the array's
        closing bracket was reached (``end`` after it), else ``end`` is at the comma after the last value --
        or None when no cut within reach separated two elements."""
        text = self.text
        pattern, comma = cut
        at = min(j + self.piece, self.n)
        for _ in range(_CUTS_TRIED):
            p = text.find(pattern, at) if at < self.absent.get(pattern, self.n + 1) else -1
            if p < 0:
                self.absent[pattern] = min(at, self.absent.get(pattern, at))
                p = self.n                     # the rest of the text: the array ends in it
                if p - j > 2 * self.piece:
                    return None
            else:
                p += comma
            chunk = "[" + text[j:p] + "]"
            try:
                values, end = _DECODER.raw_decode(chunk)
            except json.JSONDecodeError:
                if p >= self.n:
                    return None
                at = p + 1
                continue
            if end == len(chunk):              # whole elements up to the comma at p
                return values, p, False
            return values, j + end - 1, True   # the array closed at chunk[end - 1] = text[j + end - 2]
        return None
