"""Python's cyclic garbage collector paused for a block that makes many container objects at once.

A young collection runs after every 700 new containers (lists, dicts, tuples) and walks the young ones; those
that survive age into the older generations, and enough of them set off a full collection over everything the
interpreter holds.  Blocks that build many containers which all stay alive (a parsed plan's rows) or all die
together (a kd-tree's ball lists) gain nothing from those walks: reading a 1.1 MB two-paths plan set off 37
collections, one full, 22 ms of a 48 ms read; the ball lists of a free-form plan's sweep check, 39 ms.
Reference counting still frees every object that is not in a cycle while the collector is paused.
"""
import contextlib
import gc
import threading

_PAUSE_LOCK = threading.Lock()
_pause = {"depth": 0, "was_on": False}      # blocks inside collector_paused, and the collector's state before


@contextlib.contextmanager
def collector_paused():
    """The garbage collector off for the block; as it was before once the last such block ends (two workers may
    be inside at once: the first one in turns it off, the last one out restores it).

    Parsing a plan makes a list per row (300,000 for a 200,000-triangle surface).  With the collector on, those
    lists age into the oldest generation while they are made and set off 3-4 full collections, each over
    everything Python holds (in Blender, up to 100 ms in which its interface waits).  Paused, they are all still
    young when the rows become tuples and the lists are freed: the next young collection stops tracking the
    tuples, and no full collection is due."""
    with _PAUSE_LOCK:
        if _pause["depth"] == 0:
            _pause["was_on"] = gc.isenabled()
            gc.disable()
        _pause["depth"] += 1
    try:
        yield
    finally:
        with _PAUSE_LOCK:
            _pause["depth"] -= 1
            if _pause["depth"] == 0 and _pause["was_on"]:
                gc.enable()
