# SPDX-License-Identifier: GPL-3.0-or-later
"""Planning runs in the scene: each run is a collection under "Flank Results" carrying its flank-plan/1 as JSON.
Finding a run (by name, by the active object, or the newest), reading its plan, replacing an earlier run of the
same key, and removing a run with everything it made (its animation first)."""
import bpy

from .common import remove_objects
from .materials import release_attribute_material

RESULTS_COLLECTION = "Flank Results"
PLAN_JSON_PROP = "flank_plan_json"   # result collection: the run's flank-plan/1 as JSON text
ANIM_ROLE = "flank_anim_role"       # objects made by flank.animate_strip: "frame", "motion", "rotor", "strip", "tool"
ANIM_HID = "flank_anim_hid"         # names of the objects an animation hid (shown again on removal)


def results_parent(context, name=RESULTS_COLLECTION):
    """The parent collection of operator results, linked to the scene -> (collection, created).

    An existing collection of that name is reused (and linked to the scene if it is not); the caller
    removes a created one again if its own work fails."""
    coll = bpy.data.collections.get(name)
    created = coll is None
    if created:
        coll = bpy.data.collections.new(name)
    scene_root = context.scene.collection
    if coll.name not in scene_root.children:
        try:
            scene_root.children.link(coll)
        except Exception:
            if created:
                bpy.data.collections.remove(coll)
            raise
    return coll, created


def result_runs():
    """Result collections that carry a plan, oldest first."""
    parent = bpy.data.collections.get(RESULTS_COLLECTION)
    if parent is None:
        return []
    return [c for c in parent.children if PLAN_JSON_PROP in c]


def find_run(context, name=""):
    """The run named ``name``, else the one holding the active object, else the newest -> collection or an
    error message (str)."""
    if name:
        coll = bpy.data.collections.get(name)
        if coll is None:
            return "there is no collection '{}'".format(name)
        if PLAN_JSON_PROP not in coll:
            return "collection '{}' holds no plan (not a single- or double-flank run)".format(name)
        return coll
    runs = result_runs()
    ob = context.active_object
    if ob is not None:
        for coll in ob.users_collection:
            if PLAN_JSON_PROP in coll:
                return coll
    if not runs:
        return "no planning run with a plan under '{}': run Plan Single Flank or Plan Double Flank first".format(
            RESULTS_COLLECTION)
    return runs[-1]


# Plans already parsed and checked, by run: a free-form plan holds its surface (1.3 MB of JSON for 20,000
# triangles, 40-60 ms to parse and check on the main thread), and several operators read the same run's plan
_PLANS = {}                       # run collection name -> ((length, hash) of its plan text, the plan)
PLANS_KEPT = 4                    # runs whose plans are kept at most
PLAN_CHARS_KEPT = 32_000_000      # their texts' length together at most, but the last one read is always kept:
                                  # a parsed plan holds about 4.6 times its text's size in memory (5.9 MB for the
                                  # bump's 1.28 MB; more where it is mostly face indices), so about 150-250 MB


def _text_key(text):
    return len(text), hash(text)


def keep_plan(coll, text, plan):
    """Remember ``plan`` -- ``text`` parsed and checked (``validate_plan(json.loads(text))``, e.g. in a planner's
    worker) -- as the plan of the run ``coll``, whose stored plan text is ``text``: :func:`run_plan` then returns
    it while that text is unchanged."""
    _PLANS.pop(coll.name, None)
    _PLANS[coll.name] = (_text_key(text), plan)
    while len(_PLANS) > 1 and (len(_PLANS) > PLANS_KEPT
                               or sum(key[0] for key, _ in _PLANS.values()) > PLAN_CHARS_KEPT):
        _PLANS.pop(next(iter(_PLANS)))            # the one read longest ago first; the last one read stays


# a plan text longer than this is read in a worker (:class:`PlanNeeded`) when an operator defers it: about
# 25 ms of parsing and checking, and a free-form plan of 200,000 triangles (11.7 MB) takes 0.3 s
DEFER_CHARS = 1_000_000


def run_plan(context, name="", defer=False):
    """(collection, plan dict) of the run :func:`find_run` picks, or an error message (str), or with ``defer``
    a :class:`PlanNeeded` for a long plan text that is not kept parsed yet.

    The plan is parsed once per stored text (``keep_plan``; hashing the text takes 0.2-0.3 ms per MB): calls that
    read the same run share one dict, so a caller reads it and never changes it (it copies it first, as
    ``machining.rotor_body.scale_plan`` does)."""
    coll = find_run(context, name)
    if isinstance(coll, str):
        return coll
    plan = stored_plan(coll, defer)
    if isinstance(plan, PlanNeeded):
        ob = context.active_object        # active again for the second _prepare (None: none), which finds this run
        plan.name = ob.name if ob is not None else None
        return plan
    return plan if isinstance(plan, str) else (coll, plan)


def stored_plan(coll, defer=False):
    """The plan stored on the run ``coll``, kept parsed (see :func:`run_plan`), or an error message (str), or
    with ``defer`` a :class:`PlanNeeded` if the text is longer than ``DEFER_CHARS`` and not kept parsed."""
    import json

    text = coll.get(PLAN_JSON_PROP)
    kept = _PLANS.get(coll.name)
    if kept is not None and isinstance(text, str) and kept[0] == _text_key(text):
        _PLANS[coll.name] = _PLANS.pop(coll.name)       # the last read is kept longest
        return kept[1]
    if defer and isinstance(text, str) and len(text) > DEFER_CHARS:
        return PlanNeeded(coll.name, text)
    plan = _checked_plan(coll.name, text, json.loads)
    if not isinstance(plan, str):
        keep_plan(coll, text, plan)
    return plan


def _checked_plan(run_name, text, loads):
    """``parse_plan_text(text, loads)`` (a plan to keep, its surface rows as tuples), or the message (str) of a
    text that is not a valid plan."""
    from ..flank_addon.io.plan import PlanError, parse_plan_text

    try:
        return parse_plan_text(text, loads)
    except (ValueError, TypeError, OverflowError, RecursionError, PlanError) as ex:
        return "the plan stored on '{}' is not valid: {}".format(run_name, ex)


class PlanNeeded:
    """The plan of the run ``run_name``, whose stored ``text`` is long and not kept parsed (a file opened again:
    11.7 MB for a free-form plan on 200,000 triangles): :meth:`run` parses and checks it in a worker, in pieces
    (:func:`..flank_addon.io.json_pieces.loads_in_pieces`), so Blender's interface keeps running; then the
    operator's ``_prepare`` runs again and finds it kept (``ModalPlannerMixin._read_first``).  ``name``: the
    active object the operator was started with (None: none), made active again for that second ``_prepare``, so
    that it finds the same run whatever the user selected meanwhile."""

    doing = "its run's plan was read"

    def __init__(self, run_name, text):
        self.run_name, self.text, self.name = run_name, text, None

    def run(self, progress):
        """The plan checked, or the message (str) of a text that is not a valid plan (worker thread)."""
        import json

        from ..flank_addon.io.json_pieces import loads_in_pieces
        from ..flank_addon.progress import Cancelled, reporter

        if progress is None:                             # a script or background run: no interface to keep going
            loads = json.loads
        else:
            report = reporter(progress)
            message = "reading the plan of '{}' ({:.1f} MB)".format(self.run_name, len(self.text) / 1e6)
            report(0.0, message)

            def loads(text):
                return loads_in_pieces(text, progress=lambda f: report(0.9 * f, message))
        try:
            return _checked_plan(self.run_name, self.text, loads)
        except Cancelled:
            raise
        except Exception as ex:                          # reported by the operator (resume), never a traceback
            return "cannot read the plan stored on '{}': {}: {}".format(self.run_name, type(ex).__name__, ex)

    def resume(self, plan):
        """Keep the plan the worker read (main thread) -> None, or an error message (str)."""
        if isinstance(plan, str):
            return plan
        coll = bpy.data.collections.get(self.run_name)
        if coll is None or PLAN_JSON_PROP not in coll:
            return "run '{}' was removed while its plan was read".format(self.run_name)
        if coll[PLAN_JSON_PROP] == self.text:   # else a new plan was stored meanwhile: _prepare reads that one
            keep_plan(coll, self.text, plan)
        return None


def run_plan_fields(plan):
    """A planner's result fields for its run's plan (any thread, so its worker does it): ``plan_json``, the text
    stored on the run, and ``plan_checked``, that text parsed and checked again, as :func:`run_plan` would (for
    :func:`store_plan`; a dict of its own, not the planner's).  Written and read in pieces
    (``flank_addon.io.json_pieces``), so that Blender's interface runs meanwhile: at once, an 11.7 MB free-form
    plan held it for about 0.4 s to write and 0.3 s to read."""
    from ..flank_addon.io.json_pieces import dumps_in_pieces, loads_in_pieces
    from ..flank_addon.io.plan import parse_plan_text

    text = dumps_in_pieces(plan)
    return dict(plan_json=text, plan_checked=parse_plan_text(text, loads_in_pieces))


def store_plan(coll, fields):
    """Store a planner's plan on its run ``coll`` and keep it parsed: ``fields`` holds :func:`run_plan_fields`'
    ``plan_json`` and ``plan_checked`` (the main thread, in the planner's build)."""
    coll[PLAN_JSON_PROP] = fields["plan_json"]
    keep_plan(coll, fields["plan_json"], fields["plan_checked"])


def run_prop(coll, name):
    """A run's custom property under any planner's prefix (flank_sf_<name>, flank_df_<name>, ...)."""
    for key in coll.keys():
        if key.startswith("flank_") and key.endswith("_" + name) and key.count("_") == 2 + name.count("_"):
            return coll[key]
    return None


def remove_animation(coll):
    """Remove an earlier animation of this run (objects, their actions) and show again what it hid (the rotor,
    the strip's envelopes); the rotor's own data stays.  Returns the number of objects removed."""
    objs = [ob for ob in coll.objects if ANIM_ROLE in ob]
    hid = [str(name) for ob in objs for name in ob.get(ANIM_HID, ())]
    remove_objects(objs)
    for name in hid:
        ob = bpy.data.objects.get(name)
        if ob is not None:
            try:
                ob.hide_set(False)
            except RuntimeError:            # not in the current view layer
                pass
    return len(objs)


def remove_result_collection(coll):
    """Remove a result collection of an earlier run with its objects, their meshes, curves and actions (when
    no longer used elsewhere), its empty child collections, and the shared attribute material once nothing
    uses it any more; an animation of the run is removed first, showing again what it hid."""
    remove_animation(coll)
    remove_objects(list(coll.all_objects))
    for child in list(coll.children):
        if not child.all_objects:
            bpy.data.collections.remove(child)
    bpy.data.collections.remove(coll)
    release_attribute_material()


def replace_run(parent, coll, key_prop, key, name, names=()):
    """Finish a new run's collection ``coll`` (complete, linked under ``parent``): remove the collections of
    earlier runs under ``parent`` with the same ``key`` (custom property ``key_prop``), then give ``coll`` its
    ``name`` and key and the objects / meshes their wanted names, ``names`` = [(ID, name)] (made unique while
    the earlier run existed).  Returns the number of runs replaced."""
    replaced = 0
    for old in [c for c in parent.children if c != coll and c.get(key_prop) == key]:
        remove_result_collection(old)
        replaced += 1
    coll.name = name
    coll[key_prop] = key
    for id_, wanted in names:
        if id_.name != wanted:
            id_.name = wanted
    return replaced


classes = ()
register, _unregister_classes = bpy.utils.register_classes_factory(classes)


def unregister():
    _unregister_classes()
    _PLANS.clear()                # the kept plans go with the extension
