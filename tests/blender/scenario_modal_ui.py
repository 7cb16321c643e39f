# SPDX-License-Identifier: GPL-3.0-or-later
"""UI items  beside the modal run, for test_blender_modal_ui.py: the Tool panel's Check Tool button for a
cylinder (drawn into a real layout, then run with the properties the button carries), the Results panel's export
buttons (PLY included), and flank.error_plot's Image Editor hand-over without an Image Editor and with one made
in the background screen."""
import glob
import math
import os
import types

import driver
from scenario_freeform import _select_only
from scenario_sidebar import _UI

SF_KW = dict(shape="alpha", alpha=math.asin(0.1), r1=0.05, r2=0.08, shank_radius=0.04, shank_length=0.6,
             tolerance=1e-3, envelope_rings=8, seeds=6, rounds=1, flank=1)


def _draw(bpy, cls):
    """[buttons] (idname, text, properties set) of a panel drawn into a real layout by scenario_sidebar's
    recorder, or an error string."""
    drawn = _UI(bpy).draw(cls)
    if isinstance(drawn, str):
        return drawn
    buttons = []
    for call in drawn["calls"]:
        if call[0] == "operator":
            buttons.append(dict(idname=call[1], text=call[2], props={}))
        elif call[0] == "opset":                      # a property set on the button just made
            next(bt for bt in reversed(buttons) if bt["idname"] == call[1])["props"][call[2]] = call[3]
    return buttons


def _plain(v):
    return v.to_list() if hasattr(v, "to_list") else v.to_dict() if hasattr(v, "to_dict") else v


def _check_tool(bpy, res, rotor):
    panels = __import__(driver.MODULE + ".panels", fromlist=["x"])
    props = __import__(driver.MODULE + ".operators.tool_settings", fromlist=["x"])
    s = bpy.context.scene.flank_settings
    out = dict(taper=props.CYLINDER_TAPER)
    for kind in ("CONE", "CYLINDER"):
        s.tool_kind = kind
        s.sf_r1, s.sf_r2, s.sf_length, s.sf_flank = 0.05, 0.08, 0.2, 1
        _select_only(bpy, rotor)
        buttons = _draw(bpy, bpy.types.FLANK_PT_tool)
        k = dict(draw_error=buttons if isinstance(buttons, str) else None)
        if not isinstance(buttons, str):
            check = [b for b in buttons if b["idname"] == "flank.cutter_region"]
            k["buttons"] = check
            if check:
                before = {c.name for c in bpy.data.collections}
                ret, err = driver._run_op(bpy.ops.flank.cutter_region, **check[0]["props"])
                new = [c for c in bpy.data.collections if c.name not in before or c.get("flank_cr_key")]
                coll = next((c for c in new if c.get("flank_cr_key")), None)
                k.update(result=ret, error=err)
                if coll is not None:
                    k["cr"] = {key[len("flank_cr_"):]: _plain(coll[key]) for key in coll.keys()
                               if key.startswith("flank_cr_")}
        out[kind] = k
    s.tool_kind = "CONE"
    res["check_tool"] = out


def _error_plot(bpy, res, coll):
    screen = bpy.context.window_manager.windows[0].screen
    out = dict(window_in_context=bpy.context.window is not None,
               areas=[a.type for a in screen.areas])
    # no Image Editor anywhere: the plot is made, nothing to show it in, no error
    ret, err = driver._run_op(bpy.ops.flank.error_plot, collection=coll.name, width=480, height=270)
    img = next((i for i in bpy.data.images if i.get("flank_plot_run") == coll.name), None)
    out["no_editor"] = dict(result=ret, error=err, image=img.name if img else None,
                            shown=[a.spaces.active.image.name for a in screen.areas if a.type == 'IMAGE_EDITOR'
                                   and a.spaces.active.image])
    # make one: the Dope Sheet area of the background screen becomes an Image Editor
    area = next(a for a in screen.areas if a.type == 'DOPESHEET_EDITOR')
    area.type = 'IMAGE_EDITOR'
    ret, err = driver._run_op(bpy.ops.flank.error_plot, collection=coll.name, width=480, height=270)
    space = area.spaces.active
    out["editor"] = dict(result=ret, error=err, area=area.type,
                         shown=space.image.name if getattr(space, "image", None) else None,
                         images=sorted(i.name for i in bpy.data.images if i.get("flank_plot_run")))
    # the same with the window in the context (the first branch of show_in_image_editor)
    space.image = None
    with bpy.context.temp_override(window=bpy.context.window_manager.windows[0]):
        ret, err = driver._run_op(bpy.ops.flank.error_plot, collection=coll.name, width=480, height=270)
    out["editor_window"] = dict(result=ret, error=err,
                                shown=space.image.name if getattr(space, "image", None) else None)
    area.type = 'DOPESHEET_EDITOR'
    # no window in the context and a window without a screen / no window at all: nothing shown, no exception
    pp = __import__(driver.MODULE + ".operators.profile_plot", fromlist=["x"])
    img = bpy.data.images.get(out["editor"]["shown"] or "")
    no_screen = types.SimpleNamespace(window=None, window_manager=types.SimpleNamespace(
        windows=[types.SimpleNamespace(screen=None)]))
    no_window = types.SimpleNamespace(window=None, window_manager=types.SimpleNamespace(windows=[]))
    out["no_screen"] = [repr(pp.show_in_image_editor(c, img)) for c in (no_screen, no_window)]
    res["error_plot"] = out


def _results_buttons(bpy, res, coll, tmp):
    panels = __import__(driver.MODULE + ".panels", fromlist=["x"])
    buttons = _draw(bpy, bpy.types.FLANK_PT_results)
    out = dict(draw_error=buttons if isinstance(buttons, str) else None)
    if not isinstance(buttons, str):
        exports = [b for b in buttons if b["idname"] == "flank.export_results"]
        out["exports"] = [[b["text"], b["props"].get("format"), b["props"].get("collection")] for b in exports]
        ply = next((b for b in exports if b["props"].get("format") == "PLY"), None)
        if ply is not None:
            path = os.path.join(tmp, "strips.ply")
            ret, err = driver._run_op(bpy.ops.flank.export_results, filepath=path, **ply["props"])
            out["ply"] = dict(result=ret, error=err,
                              files=sorted(os.path.basename(p) for p in glob.glob(os.path.join(tmp, "strips*.ply"))))
            first = sorted(glob.glob(os.path.join(tmp, "strips*.ply")))
            if first:
                with open(first[0], "rb") as fh:
                    out["ply"]["head"] = fh.read(3).decode("ascii", "replace")
    res["results_panel"] = out


def scenario(bpy, res, args):
    tmp = os.path.dirname(os.path.abspath(args.out))
    res["window_at_start"] = bpy.context.window is not None
    driver._run_op(bpy.ops.flank.generate_rotor, kind="asymmetric", part="female", resolution=240, axial=16)
    rotor = bpy.context.active_object
    _check_tool(bpy, res, rotor)
    res["window_after_draw"] = bpy.context.window is not None
    _select_only(bpy, rotor)
    ret, err = driver._run_op(bpy.ops.flank.plan_single_flank, **SF_KW)
    res["plan"] = dict(result=ret, error=err)
    coll = next((c for c in bpy.data.collections if c.get("flank_sf_key")), None)
    if coll is None:
        return
    _select_only(bpy, bpy.context.active_object)
    _results_buttons(bpy, res, coll, tmp)
    _error_plot(bpy, res, coll)
