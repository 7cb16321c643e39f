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
PLAN_CHARS_KEPT = 32_000_000      # their texts' length together at most: a parsed plan holds about 4.6 times its
                                  # text's size in memory (5.9 MB for the bump's 1.28 MB; more where it is mostly
                                  # face indices), so about 150-250 MB at most


def _text_key(text):
    return len(text), hash(text)


def keep_plan(coll, text, plan):
    """Remember ``plan`` -- ``text`` parsed and checked (``validate_plan(json.loads(text))``, e.g. in a planner's
    worker) -- as the plan of the run ``coll``, whose stored plan text is ``text``: :func:`run_plan` then returns
    it while that text is unchanged."""
    _PLANS.pop(coll.name, None)
    if len(text) > PLAN_CHARS_KEPT:               # parsed each time it is read
        return
    _PLANS[coll.name] = (_text_key(text), plan)
    while len(_PLANS) > PLANS_KEPT or sum(key[0] for key, _ in _PLANS.values()) > PLAN_CHARS_KEPT:
        _PLANS.pop(next(iter(_PLANS)))            # the one read longest ago first


def run_plan(context, name=""):
    """(collection, plan dict) of the run :func:`find_run` picks, or an error message (str).

    The plan is parsed once per stored text (``keep_plan``; hashing the text takes 0.2-0.3 ms per MB): calls that
    read the same run share one dict, so a caller reads it and never changes it (it copies it first, as
    ``machining.rotor_body.scale_plan`` does)."""
    coll = find_run(context, name)
    if isinstance(coll, str):
        return coll
    plan = stored_plan(coll)
    return plan if isinstance(plan, str) else (coll, plan)


def stored_plan(coll):
    """The plan stored on the run ``coll``, kept parsed (see :func:`run_plan`), or an error message (str)."""
    import json

    from ..flank_addon.io.plan import PlanError, validate_plan

    text = coll.get(PLAN_JSON_PROP)
    kept = _PLANS.get(coll.name)
    if kept is not None and isinstance(text, str) and kept[0] == _text_key(text):
        _PLANS[coll.name] = _PLANS.pop(coll.name)       # the last read is kept longest
        return kept[1]
    try:
        plan = validate_plan(json.loads(text))
    except (ValueError, TypeError, PlanError) as ex:
        return "the plan stored on '{}' is not valid: {}".format(coll.name, ex)
    keep_plan(coll, text, plan)
    return plan


def run_plan_fields(plan):
    """A planner's result fields for its run's plan (any thread, so its worker does it): ``plan_json``, the text
    stored on the run, and ``plan_checked``, that text parsed and checked again, as :func:`run_plan` would (for
    :func:`store_plan`; a dict of its own, not the planner's)."""
    import json

    from ..flank_addon.io.plan import validate_plan

    text = json.dumps(plan)
    return dict(plan_json=text, plan_checked=validate_plan(json.loads(text)))


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
