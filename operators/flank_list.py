# SPDX-License-Identifier: GPL-3.0-or-later
"""The Workpiece panel's flank list and flank picking: every flank of the rotor with its valley and the hyperbolic
share of its profile (the Dupin analysis of Bizzarri, Bo & Bartoň, Sec. 4.1), the flank nearest to the 3D cursor,
and the flank under the selected faces."""
from collections import Counter

import bpy
import numpy as np
from bpy.props import IntProperty

from .common import count_limit_error, placed
from .modal import ModalPlannerMixin
from .sources import AnalysisNeeded, rotor_source, to_rotor_frame, workpiece_object
from .units import length_text


def _settings(op, context, what):
    settings = getattr(context.scene, "flank_settings", None)
    if settings is None:
        op.report({'ERROR'}, "{}: the Flank settings are not registered".format(what))
    return settings


def _rotor(obj, edit_mode_ok=False, defer=False):
    if obj is None:
        return "Select a rotor (made by Generate Rotor, or a mesh after Analyze Rotor)"
    return rotor_source(obj, "flank_ui_", edit_mode_ok, defer)


class FLANK_UL_flanks(bpy.types.UIList):
    """Flanks of the workpiece: index, valley and the hyperbolic share of its profile."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0, flt_flag=0):
        row = layout.row(align=True)
        row.label(text="Flank {}".format(item.flank), icon='MOD_SCREW')
        row.label(text="valley {}".format(item.valley))
        row.label(text="hyperbolic {:.0f} %".format(100.0 * item.hyperbolic_fraction))


class FLANK_OT_refresh_flanks(ModalPlannerMixin, bpy.types.Operator):
    """Fill the flank list of the active rotor: every flank with its valley and the share of its profile where
    a cone can touch the surface along a curve (hyperbolic points)"""

    bl_idname = "flank.refresh_flanks"
    bl_label = "Refresh Flank List"
    bl_options = {'REGISTER', 'UNDO'}

    samples: IntProperty(name="Samples", description="Profile samples per flank of the Dupin analysis (8 .. 5000)",
                         default=200, soft_min=8, soft_max=5000)

    _title = "Flank list"

    def _prepare(self, context):
        settings = _settings(self, context, "Flank list")
        if settings is None:
            return None
        msg = count_limit_error("samples", self.samples, 8, 5000)
        src = _rotor(workpiece_object(context), defer=self._defer_analysis) if msg is None else msg
        if isinstance(src, AnalysisNeeded):
            return self._read_first(src)
        if isinstance(src, str):
            self.report({'ERROR'}, "Flank list: " + src)
            return None
        return dict(surface=src["surface"], flanks=src["flanks"], scale=float(src["scale"]), name=src["obj"].name,
                    samples=int(self.samples))

    def _compute_failed(self, ex):
        return "Flank list: Dupin analysis failed: {}: {}".format(type(ex).__name__, ex)

    def _compute(self, job, progress):
        """The Dupin analysis of every flank: pure numpy (a worker thread when run from the UI)."""
        from ..flank_addon.progress import reporter
        from ..flank_addon.tooling.cutter_selection import flank_dupin

        report = reporter(progress)
        surface, flanks, s = job["surface"], job["flanks"], job["scale"]
        rows = []
        for k in range(len(flanks)):
            report(k / max(len(flanks), 1), "Dupin analysis of flank {} of {}".format(k + 1, len(flanks)))
            d = flank_dupin(surface, flanks, k, n=job["samples"])
            rows.append((k, tuple(float(v) for v in flanks[k]), float(d.hyperbolic_fraction),
                         float(d.a_min) * s if np.isfinite(d.a_min) else 0.0))
        report(1.0, "done")
        return rows

    def _build(self, context, job, rows):
        settings = _settings(self, context, "Flank list")
        if settings is None:
            return {'CANCELLED'}
        settings.flank_list.clear()
        for k, (u0, u1), frac, a_min in rows:
            item = settings.flank_list.add()
            item.name = "Flank {}".format(k)
            item.flank, item.valley, item.u_start, item.u_end = k, k // 2, u0, u1
            item.hyperbolic_fraction, item.a_min = frac, a_min
        settings.flank_list_rotor = job["name"]
        if not 0 <= settings.flank_index < len(rows):
            settings.flank_index = min(max(int(settings.sf_flank), 0), len(rows) - 1) if rows else -1
        self.report({'INFO'}, "Flank list of '{}': {} flanks, hyperbolic {}".format(
            job["name"], len(rows), ", ".join("{:.0f} %".format(100.0 * r[2]) for r in rows)))
        return {'FINISHED'}


class FLANK_OT_pick_flank_cursor(ModalPlannerMixin, bpy.types.Operator):
    """Pick the flank nearest to the 3D cursor (the cursor is screwed along its helix into the rotor's
    transverse section; the flank holding the nearest profile point is taken)"""

    bl_idname = "flank.pick_flank_cursor"
    bl_label = "Flank at 3D Cursor"
    bl_options = {'REGISTER', 'UNDO'}
    _title = "Pick flank"

    def _prepare(self, context):
        if _settings(self, context, "Pick flank") is None:
            return None
        src = _rotor(workpiece_object(context), defer=self._defer_analysis)
        if isinstance(src, AnalysisNeeded):
            return self._read_first(src)         # a rotor changed since Analyze Rotor: analysed in a worker
        if isinstance(src, str):
            self.report({'ERROR'}, "Pick flank: " + src)
            return None
        cursor = np.array(context.scene.cursor.location, dtype=np.float64)
        if not np.isfinite(cursor).all():
            self.report({'ERROR'}, "Pick flank: the 3D cursor is not at a finite location")
            return None
        return dict(src=src, name=src["obj"].name, point=to_rotor_frame(src["display"], cursor[None, :])[0])

    @staticmethod
    def _compute(job, progress):
        from ..flank_addon.methods.single_flank.planner import flank_of_point

        src, p = job["src"], job["point"]
        return int(flank_of_point(src["surface"], src["flanks"], p)), src["surface"].section_distance(p)

    def _build(self, context, job, found):
        settings = _settings(self, context, "Pick flank")
        if settings is None:
            return {'CANCELLED'}
        src, (k, dist) = job["src"], found
        settings.flank_index = k      # its update aims sf_flank and df_valley at it
        s = float(src["scale"])
        R = float(src["surface"].outer_radius) * s
        msg = "Flank {} (valley {}) of '{}': the 3D cursor is {} from the rotor surface".format(
            k, k // 2, job["name"], length_text(dist * s, context.scene, src["unit"], s))
        self.report({'WARNING'} if dist * s > 0.1 * R else {'INFO'}, msg)
        return {'FINISHED'}


def _votes(src, world):
    """Flank votes of the selected faces' centres (world coordinates) -> Counter."""
    from ..flank_addon.methods.single_flank.planner import flank_of_point

    votes = Counter()
    for p in to_rotor_frame(src["display"], world):
        if not np.isfinite(p).all():
            continue
        try:
            votes[int(flank_of_point(src["surface"], src["flanks"], p))] += 1
        except ValueError:
            continue
    return votes


class FLANK_OT_pick_flank_faces(ModalPlannerMixin, bpy.types.Operator):
    """Pick the flank under the selected faces (Edit Mode): each selected face's centre votes for its nearest
    flank, the flank with most votes is taken"""

    bl_idname = "flank.pick_flank_faces"
    bl_label = "Flank of Selected Faces"
    bl_options = {'REGISTER', 'UNDO'}
    _title = "Pick flank"

    def _prepare(self, context):
        import bmesh

        if _settings(self, context, "Pick flank") is None:
            return None
        obj = context.active_object
        if obj is None or obj.type != 'MESH' or obj.mode != 'EDIT':
            self.report({'ERROR'}, "Pick flank: select faces of the rotor mesh in Edit Mode (active object: {})"
                        .format("none" if obj is None else "'{}' in {} mode".format(obj.name, obj.mode.title())))
            return None
        bm = bmesh.from_edit_mesh(obj.data)
        centres = [tuple(f.calc_center_median()) for f in bm.faces if f.select]
        if not centres:
            self.report({'ERROR'}, "Pick flank: no face of '{}' is selected".format(obj.name))
            return None
        if obj.get("flank_source") == "analyzed":
            obj.update_from_editmode()     # the analysis reads the mesh data
        src = _rotor(obj, edit_mode_ok=True, defer=self._defer_analysis)
        if isinstance(src, AnalysisNeeded):
            return self._read_first(src)         # an edited rotor mesh: analysed in a worker
        if isinstance(src, str):
            self.report({'ERROR'}, "Pick flank: " + src)
            return None
        return dict(src=src, name=obj.name, world=placed(np.array(centres, dtype=np.float64), obj.matrix_world))

    @staticmethod
    def _compute(job, progress):
        return _votes(job["src"], job["world"])

    def _build(self, context, job, votes):
        settings = _settings(self, context, "Pick flank")
        if settings is None:
            return {'CANCELLED'}
        n_faces = len(job["world"])
        if not votes:
            self.report({'ERROR'}, "Pick flank: none of the {} selected faces lies near a flank".format(n_faces))
            return {'CANCELLED'}
        k, n = votes.most_common(1)[0]
        settings.flank_index = k
        others = ", ".join("flank {}: {}".format(f, c) for f, c in sorted(votes.items()) if f != k)
        self.report({'INFO'}, "Flank {} (valley {}) of '{}': {} of {} selected faces{}".format(
            k, k // 2, job["name"], n, n_faces, " (" + others + ")" if others else ""))
        return {'FINISHED'}


classes = (FLANK_UL_flanks, FLANK_OT_refresh_flanks, FLANK_OT_pick_flank_cursor, FLANK_OT_pick_flank_faces)
register, unregister = bpy.utils.register_classes_factory(classes)
