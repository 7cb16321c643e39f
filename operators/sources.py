# SPDX-License-Identifier: GPL-3.0-or-later
"""What an operator works on: the rotor (a generated rotor rebuilt from its custom properties, or an analysed
mesh analysed again) or the free-form surface mesh, read from Blender into the planner's terms."""
import json

import bpy
import numpy as np

from ..flank_addon.geometry.rows import used_vertices
from .common import mesh_local_arrays, mesh_triangles, mesh_vertices, placed, typed

# custom properties that point from a result object to the rotor / surface it was made from
RESULT_ROTOR_KEYS = ("flank_sf_rotor", "flank_df_rotor", "flank_cr_rotor", "flank_cutter_rotor", "flank_ff_source")
MAX_SURFACE_VERTICES = 2_000_000


def similarity_parts(matrix, rel_tol=1e-5):
    """Split a 4x4 matrix into (exact float64 similarity (4, 4), uniform scale s) or an error string.

    Blender keeps matrices in single precision: the rotation is re-orthonormalised (polar
    decomposition) so that files validated to 1e-9 accept it, and the scale is rounded to 7
    significant digits; non-uniform or mirroring scales are refused."""
    M = np.asarray(matrix, dtype=np.float64)
    A = M[:3, :3]
    det = float(np.linalg.det(A))
    if not np.isfinite(M).all() or det <= 0.0:
        return "its matrix is singular or mirrored (determinant {:.6g})".format(det)
    U, S, Vt = np.linalg.svd(A)
    s = float(np.cbrt(np.prod(S)))
    if float(S.max() - S.min()) > rel_tol * s:
        return "its scale is not uniform (singular values {})".format(", ".join("{:.6g}".format(v) for v in S))
    s = float("{:.7g}".format(s))   # single-precision matrix: the decimal scale that was typed
    out = np.eye(4)
    out[:3, :3] = s * (U @ Vt)
    out[:3, 3] = M[:3, 3]
    return out, s


def workpiece_object(context):
    """The rotor the sidebar works on: the active object, or the rotor a result object was made from."""
    obj = context.active_object
    if obj is None:
        return None
    if obj.get("flank_source") is None:
        for key in RESULT_ROTOR_KEYS:
            other = bpy.data.objects.get(str(obj.get(key, ""))) if key in obj else None
            if other is not None:
                return other
    return obj


def builtin_from_props(obj):
    """The built-in Rotor that Generate Rotor made ``obj`` from (KeyError/ValueError if it cannot)."""
    from ..flank_addon.geometry import rotors

    return rotors.builtin_rotor(str(obj["flank_kind"]), str(obj["flank_part"]), scale=float(obj["flank_scale"]),
                                lead=float(obj["flank_lead"]), length=float(obj["flank_length"]),
                                handedness=str(obj["flank_handedness"]))


def _scene_mm_factor():
    """Millimetres per scene unit, or None when the scene unit is the millimetre (a unit-less scene, or a metric
    one with unit scale 0.001).  A rotor's or a surface's own coordinates (its mesh's, before any object scale)
    are taken in scene units and made millimetres by this factor, so that a plan's figures are the millimetres its
    unit says in a scene of metres too."""
    from .units import mm_per_scene_unit

    g = typed(mm_per_scene_unit(bpy.context.scene))   # the unit scale is single precision: what was typed
    return None if g == 1.0 else g


def _in_millimetres(src, g, surface, flanks, extent):
    """The rotor source ``src`` with its rotor frame measured in millimetres: the plan's figures and files are
    then millimetres, as their unit says, in any scene unit (``g`` mm per former rotor unit; ``surface``,
    ``flanks`` and ``extent`` already scaled by g).  The display and model matrices take 1/g, so every point
    still lands where it was in the scene."""
    shrink = np.diag([1.0 / g, 1.0 / g, 1.0 / g, 1.0])
    z0, z1 = (float(z) * g for z in src["z_range"])
    return dict(src, surface=surface, flanks=flanks, display=src["display"] @ shrink,
                to_world=src["to_world"] @ shrink, scale=float(src["scale"]) / g, z_range=(z0, z1), extent=extent,
                mm_factor=g)


def own_frame(src):
    """The rotor frame in world coordinates for objects parented to the rotor object, or None when it is the
    object's own frame (a generated rotor in millimetres or units of R): an analysed mesh's frame is its
    analysis', and a rotor converted to millimetres has its frame scaled."""
    return src["display"] if src["kind"] == "analyzed" or src.get("mm_factor") else None


def _generated_rotor(obj):
    try:
        rotor = builtin_from_props(obj)
    except (KeyError, ValueError) as ex:
        return "Cannot rebuild the rotor of '{}' from its custom properties: {}".format(obj.name, ex)
    display = np.array(obj.matrix_world, dtype=np.float64)
    parts = similarity_parts(display)
    if isinstance(parts, str):
        return "Rotor '{}': {}; apply or reset its scale".format(obj.name, parts)
    to_world, scale = parts
    src = dict(obj=obj, surface=rotor.surface(), flanks=list(rotor.flanks), display=display,
               to_world=to_world, scale=scale, z_range=(0.0, float(rotor.length)), extent=rotor.extent(),
               unit="R" if float(obj["flank_scale"]) == 1.0 else "mm",
               kind="{}-{}".format(rotor.kind, rotor.part))
    g = _scene_mm_factor() if src["unit"] == "mm" else None
    if g is None:
        return src
    from ..flank_addon.geometry import rotors

    try:          # the same rotor built in millimetres (its profile exact, not a scaled sampling)
        mm = rotors.builtin_rotor(rotor.kind, rotor.part, scale=float(obj["flank_scale"]) * g,
                                  lead=float(obj["flank_lead"]) * g, length=float(obj["flank_length"]) * g,
                                  handedness=str(obj["flank_handedness"]))
    except ValueError as ex:
        return "Cannot rebuild the rotor of '{}' in millimetres: {}".format(obj.name, ex)
    return _in_millimetres(src, g, mm.surface(), list(mm.flanks), mm.extent())


def _placed_then(obj, co, known):
    """(the world vertices the analysis record was made from, the motion from there to now) when the object
    moved since Analyze Rotor, else None: the analysis then moves with the object instead of being made again
    on the main thread (a second for 280,000 triangles).  ``co``: the mesh's own vertices."""
    if not isinstance(known, dict):
        return None
    try:                        # a property that is not 16 numbers (edited by hand, another tool): not taken
        m_then = np.array([float(x) for x in obj.get("flank_analysis_matrix")], dtype=np.float64).reshape(4, 4)
        m_now = np.array(obj.matrix_world, dtype=np.float64)
        if np.array_equal(m_then, m_now) or not np.isfinite(m_then).all():
            return None
        motion = m_now @ np.linalg.inv(m_then)
    except (TypeError, ValueError, np.linalg.LinAlgError):
        return None
    return placed(co, m_then), motion


class AnalysisNeeded:
    """An analysed rotor whose mesh is not the one Analyze Rotor recorded (scaled, mirrored or edited since, or
    a record of older analysing code): the analysis runs in a worker (:meth:`run`, about a second for 280,000
    triangles) before the operator reads the rotor again, now from the analysis cache.  ``name``: the object
    the operator was started on (a result object or the rotor itself)."""

    doing = "its rotor was analysed"

    def __init__(self, name, rotor_name, verts, faces):
        self.name, self.rotor_name, self.verts, self.faces = name, rotor_name, verts, faces

    def resume(self, result):
        """Nothing to do on the main thread: the analysis is in the cache (``ModalPlannerMixin._read_first``)."""
        return None

    def run(self, progress):
        """The analysis, kept in the analysis cache (worker thread); the rotor's own message if it is not
        helical."""
        from ..flank_addon.geometry.rotor_analysis import NotHelicalError, analyze_mesh
        from ..flank_addon.progress import Cancelled, reporter

        stage = reporter(progress)

        def report(fraction, message):
            stage(fraction, "analysing '{}' again (its mesh changed since Analyze Rotor): {}".format(
                self.rotor_name, message))

        report(0.0, "reading")
        try:
            analyze_mesh(self.verts, self.faces, progress=report)
        except NotHelicalError as ex:
            raise RotorSourceError("'{}' is not a helical rotor: {}".format(self.rotor_name, ex)) from None
        except Cancelled:
            raise
        except Exception as ex:
            raise RotorSourceError("Cannot analyze '{}' again: {}: {}".format(
                self.rotor_name, type(ex).__name__, ex)) from None


class RotorSourceError(ValueError):
    """The rotor cannot be read: the operator reports its title and this message, as when it is read on the main
    thread."""


def _analyzed_rotor(obj, defer=False):
    from ..flank_addon.geometry.rotor_analysis import NotHelicalError, analysis_at_hand, analyze_mesh

    try:
        co, faces = mesh_local_arrays(obj)
        verts = placed(co, obj.matrix_world)
        # Analyze Rotor's record: taken when the mesh is still the one it was made from (a file opened again
        # needs no second analysis on the main thread), ignored otherwise
        try:
            known = json.loads(obj.get("flank_analysis_record", "null"))
        except (TypeError, ValueError):
            known = None
        known_at = _placed_then(obj, co, known)
        if defer:
            a = analysis_at_hand(verts, faces, known=known, known_at=known_at)
            if a is None:
                return AnalysisNeeded(obj.name, obj.name, verts, faces)
        else:
            a = analyze_mesh(verts, faces, known=known, known_at=known_at)
        surface, flanks = a.surface, a.flank_ranges()
        to_world = np.asarray(a.to_world, dtype=np.float64)
    except NotHelicalError as ex:
        return "'{}' is not a helical rotor: {}".format(obj.name, ex)
    except Exception as ex:
        return "Cannot analyze '{}' again: {}: {}".format(obj.name, type(ex).__name__, ex)
    parts = similarity_parts(to_world)
    if isinstance(parts, str):
        return "Analysis of '{}': {}".format(obj.name, parts)
    to_world, scale = parts
    z = [float(v) for v in a.body_z] if getattr(a, "body_z", None) is not None else [0.0, 0.0]
    extent = _extent(a) if z[1] > z[0] else None
    if not z[1] > z[0]:
        z = [0.0, 2.0 * float(a.outer_radius)]
    src = dict(obj=obj, surface=surface, flanks=flanks, display=to_world, to_world=to_world,
               scale=scale, z_range=(z[0], z[1]), extent=extent, unit="mm", kind="analyzed")
    g = _scene_mm_factor()
    if g is None:
        return src
    from ..flank_addon.geometry.flank_feet import flank_u_ranges
    from ..flank_addon.geometry.helical_surface import shared_surface
    from ..flank_addon.geometry.profile import SplineProfile
    from ..flank_addon.io.plan import scaled_extent

    mm = shared_surface(SplineProfile(np.asarray(a.profile, dtype=np.float64) * g), float(a.v0) * g, a.handedness)
    return _in_millimetres(src, g, mm, flank_u_ranges(mm.profile, [(int(i), int(j)) for i, j in a.flanks]),
                           None if extent is None else scaled_extent(extent, g))


def _extent(analysis):
    """The analysed rotor's body z range and shafts as flank-plan/1's ``rotor.extent`` (None if not valid)."""
    from ..flank_addon.io.plan import PlanError, rotor_extent

    ext = analysis.extent()
    try:
        return rotor_extent(ext["z_range"], ext["shafts"])
    except (PlanError, KeyError, TypeError, ValueError):
        return None


def with_extent(plan, extent):
    """The plan with the finite rotor it was planned on (``rotor.extent``: body z range and shafts, as the
    command line's planners record it), when the rotor source knows it."""
    if extent is not None and plan.get("rotor") is not None:
        plan["rotor"]["extent"] = extent
    return plan


def rotor_source(obj, prop_prefix="", edit_mode_ok=False, defer=False):
    """The rotor a planning operator works on -> dict (obj, surface, flanks, display, to_world, scale, z_range,
    extent (a plan's rotor.extent, or None), unit, kind), or an error message (str).  ``obj`` may be a generated
    rotor, an analysed mesh, or a result object whose ``<prop_prefix>rotor`` names its rotor; ``edit_mode_ok``:
    the caller synced an object in Edit Mode (update_from_editmode).  ``defer``: an analysed mesh that must be
    analysed again gives an :class:`AnalysisNeeded` instead of blocking the caller for the analysis."""
    started_on = obj.name if obj is not None else ""
    if obj is not None and prop_prefix and prop_prefix + "rotor" in obj and obj.get("flank_source") is None:
        other = bpy.data.objects.get(obj[prop_prefix + "rotor"])  # a result object: use its rotor
        if other is not None:
            obj = other
    if obj is None or obj.type != 'MESH':
        return "Select a rotor made by Generate Rotor or an analyzed rotor mesh (active object: {})".format(
            "none" if obj is None else "'{}' ({})".format(obj.name, obj.type))
    if obj.mode != 'OBJECT' and not edit_mode_ok:
        return "Switch '{}' to Object Mode first".format(obj.name)
    src = obj.get("flank_source")
    if src == "generated":
        return _generated_rotor(obj)
    if src == "analyzed":
        found = _analyzed_rotor(obj, defer)
        if isinstance(found, AnalysisNeeded):
            found.name = started_on
        return found
    return ("'{}' is not a rotor (flank_source = {!r}): select a rotor made by Generate Rotor or run "
            "Analyze Rotor on the mesh first".format(obj.name, src))


def to_rotor_frame(display, points_world):
    """World points (N, 3) -> rotor frame (N, 3) through the rotor's display matrix (rotor frame -> world)."""
    p = np.c_[np.asarray(points_world, dtype=np.float64).reshape(-1, 3), np.ones(len(points_world))]
    q = np.linalg.solve(display, p.T).T
    return q[:, :3] / q[:, 3:4]


# ---------------------------------------------------------------------------------------------- free-form
def surface_object(context, role_key="flank_ff_role", source_key="flank_ff_source"):
    """The mesh to plan on: the active object, or the surface a free-form result object was made from."""
    obj = context.active_object
    if obj is not None and obj.get(role_key) is not None:
        other = bpy.data.objects.get(str(obj.get(source_key, "")))
        if other is not None:
            obj = other
    return obj


def _triangles(mesh, selected_only, co):
    """(triangles (m, 3), their polygon indices) of a mesh whose vertices are ``co``, only those of selected faces
    if asked."""
    tris, poly = mesh_triangles(mesh, with_faces=True, co=co)
    tris, poly = tris.astype(np.int64), poly.astype(np.int64)
    if selected_only:
        sel = np.zeros(len(mesh.polygons), dtype=bool)
        mesh.polygons.foreach_get("select", sel)
        keep = sel[poly]
        tris, poly = tris[keep], poly[keep]
    return tris, poly


def _field(obj, name, used, poly):
    """The guiding vector field of the attribute ``name`` on the used vertices / triangles, or a message."""
    attr = obj.data.attributes.get(name)
    if attr is None:
        return "'{}' has no attribute '{}' (the guiding vector field)".format(obj.name, name)
    if attr.data_type != 'FLOAT_VECTOR' or attr.domain not in ('POINT', 'FACE'):
        return "attribute '{}' of '{}' is {} on {}: the guiding field must be FLOAT_VECTOR on POINT or FACE"\
            .format(name, obj.name, attr.data_type, attr.domain)
    vals = np.empty(3 * len(attr.data), dtype=np.float64)
    attr.data.foreach_get("vector", vals)
    vals = vals.reshape(-1, 3)
    field = vals[used] if attr.domain == 'POINT' else vals[poly]
    if not np.isfinite(field).all():
        return "attribute '{}' of '{}' holds values that are not finite numbers".format(name, obj.name)
    return field


def surface_source(obj, selected_only=False, field_attribute="", preview_prop=""):
    """A mesh object's triangles in its local coordinates, in millimetres -> dict(obj, V (n, 3), F (m, 3), to_world
    (4, 4) similarity (millimetres -> world), scale (scene units per mm), field (n or m, 3) or None), or an error
    message (str)."""
    if obj is None or obj.type != 'MESH':
        return "select a mesh object: the surface to machine (active object: {})".format(
            "none" if obj is None else "'{}' ({})".format(obj.name, obj.type))
    if preview_prop and obj.get(preview_prop) is not None:
        return "'{}' is the guiding-curve preview, not a surface".format(obj.name)
    if obj.mode == 'EDIT':
        obj.update_from_editmode()
    parts = similarity_parts(obj.matrix_world)
    if isinstance(parts, str):
        return "'{}': {}; apply its scale first".format(obj.name, parts)
    mesh = obj.data
    n = len(mesh.vertices)
    if n == 0 or len(mesh.polygons) == 0:
        return "'{}' has no faces".format(obj.name)
    if n > MAX_SURFACE_VERTICES:
        return "'{}' has {} vertices, above the limit {}".format(obj.name, n, MAX_SURFACE_VERTICES)
    co = mesh_vertices(mesh)
    if not np.isfinite(co).all():
        return "'{}' has vertices that are not finite numbers (NaN or infinity)".format(obj.name)
    tris, poly = _triangles(mesh, selected_only, co)
    if not len(tris):
        return "'{}' has no selected faces (Selected Faces Only is on)".format(obj.name)
    used, F = used_vertices(tris, n)
    field = _field(obj, field_attribute, used, poly) if field_attribute else None
    if isinstance(field, str):
        return field
    V, to_world, scale = co[used], parts[0], parts[1]
    g = _scene_mm_factor()
    if g is not None:         # the plan is in millimetres, as it says, whatever the scene's unit
        V, to_world, scale = V * g, to_world @ np.diag([1.0 / g, 1.0 / g, 1.0 / g, 1.0]), scale / g
    return dict(obj=obj, V=V, F=F, to_world=to_world, scale=scale, field=field)


classes = ()
register, unregister = bpy.utils.register_classes_factory(classes)
