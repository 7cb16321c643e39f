# SPDX-License-Identifier: GPL-3.0-or-later
"""Small helpers shared by the operators (bpy only; numpy passed in)."""

# Object custom properties written by the operators.
PLAN_JSON_PROP = "flank_plan_json"   # result collection: the run's flank-plan/1 as JSON text
PROP_KEYS = (
    "flank_source", "flank_kind", "flank_part", "flank_lobes", "flank_scale", "flank_lead", "flank_length",
    "flank_v0", "flank_handedness", "flank_axis", "flank_axis_point", "flank_residual", "flank_threshold",
    "flank_flanks", "flank_flank_count", "flank_outer_radius", "flank_to_world", "flank_analysis",
)

# RGBA per curvature class (+1 elliptic, 0 parabolic, -1 hyperbolic)
CLASS_COLORS = {
    1: (0.90, 0.25, 0.15, 1.0),
    0: (0.85, 0.85, 0.80, 1.0),
    -1: (0.15, 0.40, 0.90, 1.0),
}


def new_mesh_from_arrays(bpy, np, name, verts, faces):
    """Create a mesh datablock from (N,3) vertices and (M,3) triangles with foreach_set.

    The datablock is removed again if anything fails, so callers never see half-built data.
    """
    verts = np.ascontiguousarray(verts, dtype=np.float32).reshape(-1, 3)
    faces = np.ascontiguousarray(faces, dtype=np.int32).reshape(-1, 3)
    if len(verts) == 0 or len(faces) == 0:
        raise ValueError("empty mesh")
    if faces.min() < 0 or faces.max() >= len(verts):
        raise ValueError("face index out of range")
    mesh = bpy.data.meshes.new(name)
    try:
        mesh.vertices.add(len(verts))
        mesh.vertices.foreach_set("co", verts.ravel())
        mesh.loops.add(faces.size)
        mesh.loops.foreach_set("vertex_index", faces.ravel())
        mesh.polygons.add(len(faces))
        mesh.polygons.foreach_set("loop_start", np.arange(0, faces.size, 3, dtype=np.int32))
        mesh.update(calc_edges=True)
        mesh.validate(clean_customdata=False)
    except Exception:
        bpy.data.meshes.remove(mesh)
        raise
    return mesh


def mesh_world_arrays(np, obj):
    """World-space vertices (N,3 float64) and triangles (M,3 int) of a mesh object's base mesh.

    Analysis results are therefore stored in world coordinates (axis, v0 in scene units, to_world).
    """
    mesh = obj.data
    n = len(mesh.vertices)
    co = np.empty(n * 3, dtype=np.float64)
    mesh.vertices.foreach_get("co", co)
    co = co.reshape(n, 3)
    mw = np.array(obj.matrix_world, dtype=np.float64)
    verts = co @ mw[:3, :3].T + mw[:3, 3]
    mesh.calc_loop_triangles()
    tris = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int32)
    mesh.loop_triangles.foreach_get("vertices", tris)
    return verts, tris.reshape(-1, 3)


def clear_flank_props(obj):
    for key in PROP_KEYS:
        if key in obj:
            del obj[key]


def select_only(context, obj):
    for other in context.view_layer.objects:
        if other.select_get():
            other.select_set(False)
    obj.select_set(True)
    context.view_layer.objects.active = obj


def revolved_mesh(np, rh, n=48):
    """Closed surface of revolution about the local z-axis as (verts (V,3), faces (F,3)), outward oriented.

    ``rh`` (K, 2) meridian points (radius, height) from the top pole to the bottom pole, both with
    radius 0 (K >= 3); every inner point is revolved into a ring of ``n`` vertices.
    """
    rh = np.asarray(rh, dtype=np.float64)
    rings = rh[1:-1]
    m = len(rings)
    if m < 1 or n < 3:
        raise ValueError("a revolved mesh needs >= 3 meridian points and >= 3 segments")
    ang = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    verts = np.empty((m * n + 2, 3))
    verts[:m * n, 0] = (rings[:, 0:1] * np.cos(ang)[None, :]).ravel()
    verts[:m * n, 1] = (rings[:, 0:1] * np.sin(ang)[None, :]).ravel()
    verts[:m * n, 2] = np.repeat(rings[:, 1], n)
    verts[m * n] = (0.0, 0.0, rh[0, 1])
    verts[m * n + 1] = (0.0, 0.0, rh[-1, 1])
    i = np.arange(n)
    j = (i + 1) % n
    faces = []
    for k in range(m - 1):  # ring k above ring k + 1: CCW seen from outside
        a, b = k * n + i, k * n + j
        faces += [np.c_[a, a + n, b + n], np.c_[a, b + n, b]]
    top, bot = m * n, m * n + 1
    faces += [np.c_[np.full(n, top), i, j], np.c_[np.full(n, bot), (m - 1) * n + j, (m - 1) * n + i]]
    return verts, np.vstack(faces)


def frame_along(np, p0, p1):
    """Orthonormal (3,3) rotation whose third column is the unit direction p0 -> p1 (None if p0 == p1)."""
    ax = np.asarray(p1, dtype=np.float64) - np.asarray(p0, dtype=np.float64)
    length = float(np.linalg.norm(ax))
    if length < 1e-12:
        return None, 0.0
    ax = ax / length
    ref = np.array([1.0, 0.0, 0.0]) if abs(ax[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(ax, ref)
    e1 /= np.linalg.norm(e1)
    return np.column_stack([e1, np.cross(ax, e1), ax]), length


def remove_ids(bpy, objects=(), meshes=(), collections=()):
    """Best-effort removal of data created by a failed operator (objects first)."""
    for ob in objects:
        try:
            bpy.data.objects.remove(ob)
        except (ReferenceError, RuntimeError):
            pass
    for me in meshes:
        try:
            bpy.data.meshes.remove(me)
        except (ReferenceError, RuntimeError):
            pass
    for coll in collections:
        try:
            bpy.data.collections.remove(coll)
        except (ReferenceError, RuntimeError):
            pass


def edge_mesh(bpy, np, name, chains):
    """Mesh of polylines (vertices + edges only): ``chains`` is a list of ((K, 3) points, closed)."""
    verts, edges, off = [], [], 0
    for pts, closed in chains:
        k = len(pts)
        idx = np.arange(k) + off
        e = np.c_[idx[:-1], idx[1:]]
        if closed:
            e = np.vstack([e, [[idx[-1], idx[0]]]])
        verts.append(pts)
        edges.append(e)
        off += k
    verts = np.ascontiguousarray(np.vstack(verts), dtype=np.float32)
    edges = np.ascontiguousarray(np.vstack(edges), dtype=np.int32)
    mesh = bpy.data.meshes.new(name)
    try:
        mesh.vertices.add(len(verts))
        mesh.vertices.foreach_set("co", verts.ravel())
        mesh.edges.add(len(edges))
        mesh.edges.foreach_set("vertices", edges.ravel())
        mesh.update()
        mesh.validate(clean_customdata=False)
    except Exception:
        bpy.data.meshes.remove(mesh)
        raise
    return mesh


def set_float_attr(np, mesh, name, values, domain='POINT'):
    """(Re)create a FLOAT attribute ``name`` with ``values``."""
    old = mesh.attributes.get(name)
    if old is not None:
        mesh.attributes.remove(old)
    attr = mesh.attributes.new(name, 'FLOAT', domain)
    attr.data.foreach_set("value", np.ascontiguousarray(values, dtype=np.float32))
    return attr


def set_color_attr(np, mesh, name, rgba):
    """(Re)create a FLOAT_COLOR point attribute and make it the active and render colour."""
    old = mesh.color_attributes.get(name)
    if old is not None:
        mesh.color_attributes.remove(old)
    attr = mesh.color_attributes.new(name, 'FLOAT_COLOR', 'POINT')
    attr.data.foreach_set("color", np.ascontiguousarray(rgba, dtype=np.float32).ravel())
    mesh.color_attributes.active_color = attr
    try:
        mesh.color_attributes.render_color_index = mesh.color_attributes.active_color_index
    except (AttributeError, TypeError):
        pass
    return attr


def iter_fcurves(action):
    """F-curves of an action, legacy (Blender < 4.4) or layered/slotted (4.4+, only API in 5.x)."""
    layers = getattr(action, "layers", None)
    if layers:
        for layer in layers:
            for strip in layer.strips:
                for bag in getattr(strip, "channelbags", ()):
                    yield from bag.fcurves
    else:
        yield from getattr(action, "fcurves", ())


def screw_matrix(np, t, v0, hand):
    """4x4 matrix of the screw motion S_t about the z-axis (turn hand * t, advance v0 * t)."""
    c, s = np.cos(hand * t), np.sin(hand * t)
    m = np.eye(4)
    m[0, 0], m[0, 1], m[1, 0], m[1, 1] = c, -s, s, c
    m[2, 3] = v0 * t
    return m


RESULTS_COLLECTION = "Flank Results"


def results_parent(bpy, context, name=RESULTS_COLLECTION):
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


def similarity_parts(np, matrix, rel_tol=1e-5):
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


def key_screw_motion(motion, keys, v0, eps):
    """LINEAR keys of the screw motion on an object about its parent's z axis: ``keys`` is
    [(frame, t), ...] (turn eps t, advance v0 t).  Returns the action (None if none was made)."""
    for f, t in keys:
        motion.location = (0.0, 0.0, v0 * t)
        motion.rotation_euler = (0.0, 0.0, eps * t)
        motion.keyframe_insert(data_path="location", index=2, frame=f)
        motion.keyframe_insert(data_path="rotation_euler", index=2, frame=f)
    ad = motion.animation_data
    if ad is None or ad.action is None:
        return None
    for fcu in iter_fcurves(ad.action):
        for kp in fcu.keyframe_points:
            kp.interpolation = 'LINEAR'
    return ad.action


def builtin_from_props(rotors, obj):
    """The built-in Rotor that Generate Rotor made ``obj`` from (KeyError/ValueError if it cannot)."""
    return rotors.builtin_rotor(str(obj["flank_kind"]), str(obj["flank_part"]), scale=float(obj["flank_scale"]),
                                lead=float(obj["flank_lead"]), length=float(obj["flank_length"]),
                                handedness=str(obj["flank_handedness"]))


def rotor_source(bpy, context, np, prop_prefix):
    """The rotor a planning operator works on -> dict (obj, surface, flanks, display, to_world, scale,
    z_range, unit, kind), or an error message (str).  The active object may be a generated rotor, an
    analysed mesh, or a result object whose ``<prop_prefix>rotor`` names its rotor."""
    from ..flank_addon.geometry import rotors

    obj = context.active_object
    if obj is not None and prop_prefix + "rotor" in obj and obj.get("flank_source") is None:
        other = bpy.data.objects.get(obj[prop_prefix + "rotor"])  # a result object: use its rotor
        if other is not None:
            obj = other
    if obj is None or obj.type != 'MESH':
        return "Select a rotor made by Generate Rotor or an analyzed rotor mesh (active object: {})".format(
            "none" if obj is None else "'{}' ({})".format(obj.name, obj.type))
    if obj.mode != 'OBJECT':
        return "Switch '{}' to Object Mode first".format(obj.name)
    src = obj.get("flank_source")
    if src == "generated":
        try:
            rotor = builtin_from_props(rotors, obj)
        except (KeyError, ValueError) as ex:
            return "Cannot rebuild the rotor of '{}' from its custom properties: {}".format(obj.name, ex)
        display = np.array(obj.matrix_world, dtype=np.float64)
        parts = similarity_parts(np, display)
        if isinstance(parts, str):
            return "Rotor '{}': {}; apply or reset its scale".format(obj.name, parts)
        to_world, scale = parts
        return dict(obj=obj, surface=rotor.surface(), flanks=list(rotor.flanks), display=display,
                    to_world=to_world, scale=scale, z_range=(0.0, float(rotor.length)),
                    unit="R" if float(obj["flank_scale"]) == 1.0 else "mm",
                    kind="{}-{}".format(rotor.kind, rotor.part))
    if src == "analyzed":
        from ..flank_addon.geometry.flank_feet import flank_u_ranges
        from ..flank_addon.geometry.helical_surface import HelicalSurface
        from ..flank_addon.geometry.profile import SplineProfile
        from ..flank_addon.geometry.rotor_analysis import NotHelicalError, analyze_mesh

        try:
            verts, faces = mesh_world_arrays(np, obj)
            a = analyze_mesh(verts, faces)
            prof = SplineProfile(a.profile)
            surface = HelicalSurface(prof, a.v0, a.handedness)
            flanks = flank_u_ranges(prof, [(int(i), int(j)) for i, j in a.flanks])
            to_world = np.asarray(a.to_world, dtype=np.float64)
        except NotHelicalError as ex:
            return "'{}' is not a helical rotor: {}".format(obj.name, ex)
        except Exception as ex:
            return "Cannot analyze '{}' again: {}: {}".format(obj.name, type(ex).__name__, ex)
        parts = similarity_parts(np, to_world)
        if isinstance(parts, str):
            return "Analysis of '{}': {}".format(obj.name, parts)
        to_world, scale = parts
        z = [float(v) for v in a.body_z] if getattr(a, "body_z", None) is not None else [0.0, 0.0]
        if not z[1] > z[0]:
            z = [0.0, 2.0 * float(a.outer_radius)]
        return dict(obj=obj, surface=surface, flanks=flanks, display=to_world, to_world=to_world,
                    scale=scale, z_range=(z[0], z[1]), unit="mm", kind="analyzed")
    return ("'{}' is not a rotor (flank_source = {!r}): select a rotor made by Generate Rotor or run "
            "Analyze Rotor on the mesh first".format(obj.name, src))


def count_limit_error(label, value, lo, hi):
    """Message for an integer setting outside [lo, hi] (sizes that would exhaust memory or mean nothing),
    or None."""
    v = int(value)
    if lo <= v <= hi:
        return None
    return "{} = {} is outside the limits {}..{}".format(label, v, lo, hi)


# ---------------------------------------------------------------------------------------- result runs
def remove_objects(bpy, objs):
    """Remove objects, then their meshes, curves and actions that nothing else uses any more (linked copies
    keep their shared data)."""
    meshes = {ob.data for ob in objs if ob.type == 'MESH' and ob.data is not None}
    curves = {ob.data for ob in objs if ob.type == 'CURVE' and ob.data is not None}
    actions = {ob.animation_data.action for ob in objs if ob.animation_data and ob.animation_data.action}
    for ob in objs:
        bpy.data.objects.remove(ob)
    for ids, blocks in ((meshes, bpy.data.meshes), (curves, bpy.data.curves), (actions, bpy.data.actions)):
        for block in ids:
            if block.users == 0:
                blocks.remove(block)


def remove_result_collection(bpy, coll):
    """Remove a result collection of an earlier run with its objects, their meshes, curves and actions (when
    no longer used elsewhere), its empty child collections, and the shared attribute material once nothing
    uses it any more; an animation of the run (flank.animate_strip) is removed first, showing again what it
    hid."""
    from .animate import remove_animation

    remove_animation(coll)
    remove_objects(bpy, list(coll.all_objects))
    for child in list(coll.children):
        if not child.all_objects:
            bpy.data.collections.remove(child)
    bpy.data.collections.remove(coll)
    release_attribute_material(bpy)


def replace_run(bpy, parent, coll, key_prop, key, name, names=()):
    """Finish a new run's collection ``coll`` (complete, linked under ``parent``): remove the collections of
    earlier runs under ``parent`` with the same ``key`` (custom property ``key_prop``), then give ``coll`` its
    ``name`` and key and the objects / meshes their wanted names, ``names`` = [(ID, name)] (made unique while
    the earlier run existed).  Returns the number of runs replaced."""
    replaced = 0
    for old in [c for c in parent.children if c != coll and c.get(key_prop) == key]:
        remove_result_collection(bpy, old)
        replaced += 1
    coll.name = name
    coll[key_prop] = key
    for id_, wanted in names:
        if id_.name != wanted:
            id_.name = wanted
    return replaced


# ---------------------------------------------------------------------------------------- attribute colours
ATTRIBUTE_MATERIAL = "Flank Attribute Colour"
ATTRIBUTE_MATERIAL_PROP = "flank_attribute_material"   # marks the material made here (found again if renamed)


def _find_attribute_material(bpy):
    for mat in bpy.data.materials:
        if mat.get(ATTRIBUTE_MATERIAL_PROP) is not None and mat.library is None:
            return mat
    return None


def attribute_material(bpy):
    """The one shared material of the result objects -> (material, created): it shows the mesh's render colour
    attribute (a Color Attribute node with no name, into the Principled BSDF's base and emission colour) in
    Material Preview, Rendered and Cycles.  A created material has no users yet: the caller assigns it
    (:func:`assign_attribute_material`) or removes it again (:func:`release_attribute_material`)."""
    mat = _find_attribute_material(bpy)
    if mat is not None:
        return mat, False
    mat = bpy.data.materials.new(ATTRIBUTE_MATERIAL)
    try:
        if getattr(mat, "node_tree", None) is None or bpy.app.version < (5, 0, 0):
            mat.use_nodes = True                 # Blender 4.x; 5.x materials always have a node tree
        nt = mat.node_tree
        nt.nodes.clear()
        out = nt.nodes.new("ShaderNodeOutputMaterial")
        out.location = (300.0, 0.0)
        bsdf = nt.nodes.new("ShaderNodeBsdfPrincipled")
        bsdf.location = (0.0, 0.0)
        col = nt.nodes.new("ShaderNodeVertexColor")      # "Color Attribute"; no name = the render colour
        col.location = (-300.0, 0.0)
        col.layer_name = ""
        nt.links.new(col.outputs["Color"], bsdf.inputs["Base Color"])
        emit = bsdf.inputs.get("Emission Color") or bsdf.inputs.get("Emission")
        strength = bsdf.inputs.get("Emission Strength")
        if emit is not None and strength is not None:    # a little glow: the colours read in a dim scene
            nt.links.new(col.outputs["Color"], emit)
            strength.default_value = 0.25
        rough = bsdf.inputs.get("Roughness")
        if rough is not None:
            rough.default_value = 0.6
        nt.links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
        mat.diffuse_color = (0.8, 0.8, 0.8, 1.0)
        mat[ATTRIBUTE_MATERIAL_PROP] = 1
    except Exception:
        bpy.data.materials.remove(mat)
        raise
    return mat, True


def assign_attribute_material(mesh, mat, only_if_none=False):
    """Put the shared attribute material in slot 0 of ``mesh`` (``only_if_none``: only when the mesh has no
    material yet, for a user's own mesh).  Returns True when the mesh was changed."""
    mats = mesh.materials
    if len(mats) == 0:
        mats.append(mat)
        return True
    if only_if_none and any(m is not None for m in mats):
        return False
    if mats[0] != mat:
        mats[0] = mat
        return True
    return False


def release_attribute_material(bpy, mat=None):
    """Remove the shared attribute material when nothing uses it any more (no orphan data is left)."""
    if mat is None:
        mat = _find_attribute_material(bpy)
    try:
        if mat is not None and mat.users == 0:
            bpy.data.materials.remove(mat)
    except ReferenceError:
        pass


_SHADING_SWITCHED = set()     # View3D shading settings switched to Attribute colours once (never again)


def show_attribute_colors(bpy, context):
    """After a successful run: 3D Viewports in Solid mode colouring by Material (the default) switch to
    Attribute colours once each, so the strips' error colours show.  Nothing happens in background mode, and
    a viewport the user switched back keeps the user's choice."""
    if bpy.app.background:
        return 0
    switched = 0
    wm = getattr(context, "window_manager", None)
    screens = []
    for win in (getattr(wm, "windows", None) or ()):
        if win.screen is not None and win.screen not in screens:
            screens.append(win.screen)
    if getattr(context, "screen", None) is not None and context.screen not in screens:
        screens.append(context.screen)
    for screen in screens:
        for area in screen.areas:
            if area.type != 'VIEW_3D':
                continue
            for space in area.spaces:
                if space.type != 'VIEW_3D':
                    continue
                shading = getattr(space, "shading", None)
                if shading is None:
                    continue
                ptr = shading.as_pointer()
                if ptr in _SHADING_SWITCHED:
                    continue
                _SHADING_SWITCHED.add(ptr)
                try:
                    if shading.color_type == 'MATERIAL':
                        shading.color_type = 'VERTEX'
                        switched += 1
                except (AttributeError, TypeError, RuntimeError):
                    pass
    return switched


class RunMaterial:
    """The shared attribute material for one run, fetched or made on first use: ``assign(mesh)`` puts it on a
    result mesh; ``discard()`` (a failed run, after its meshes are removed) removes it again if this run made
    it, so nothing is left behind."""

    def __init__(self, bpy):
        self.bpy, self.mat, self.created = bpy, None, False

    def assign(self, mesh, only_if_none=False):
        if self.mat is None:
            self.mat, self.created = attribute_material(self.bpy)
        return assign_attribute_material(mesh, self.mat, only_if_none)

    def discard(self):
        if self.created and self.mat is not None:
            release_attribute_material(self.bpy, self.mat)
        self.mat, self.created = None, False
