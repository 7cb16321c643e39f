# SPDX-License-Identifier: GPL-3.0-or-later
"""Blender data helpers shared by the operators: meshes from numpy arrays, attributes, removal of data made by
a failed operator, selection, F-curves and the screw-motion keys, input limits.

This is the bottom of the Blender layer: it imports no other module of ``operators`` or ``panels``."""
import os

import bpy
import numpy as np

from ..flank_addon.io.files import output_path_error

# Object custom properties written by Generate Rotor / Analyze Rotor (cleared before a new analysis).
PROP_KEYS = (
    "flank_source", "flank_kind", "flank_part", "flank_lobes", "flank_scale", "flank_lead", "flank_length",
    "flank_v0", "flank_handedness", "flank_axis", "flank_axis_point", "flank_residual", "flank_threshold",
    "flank_flanks", "flank_flank_count", "flank_outer_radius", "flank_to_world", "flank_analysis",
    "flank_analysis_record", "flank_analysis_matrix",
)

# RGBA per curvature class (+1 elliptic, 0 parabolic, -1 hyperbolic)
CLASS_COLORS = {
    1: (0.90, 0.25, 0.15, 1.0),
    0: (0.85, 0.85, 0.80, 1.0),
    -1: (0.15, 0.40, 0.90, 1.0),
}


def typed(value):
    """Blender float properties are single precision: the decimal value that was typed (7 significant digits)."""
    return float("{:.7g}".format(value))


def count_limit_error(label, value, lo, hi):
    """Message for an integer setting outside [lo, hi] (sizes that would exhaust memory or mean nothing),
    or None."""
    v = int(value)
    if lo <= v <= hi:
        return None
    return "{} = {} is outside the limits {}..{}".format(label, v, lo, hi)


# ---------------------------------------------------------------------------------------------- meshes
def new_mesh_from_arrays(name, verts, faces):
    """Create a mesh datablock from (N,3) vertices and (M,3) triangles with foreach_set.

    The datablock is removed again if anything fails, so callers never see half-built data.  The arrays come
    from the planner's own grids, so Blender's ``validate`` (120 ms for 280,000 triangles, half of the whole
    build) runs only where it could change something: a triangle that repeats a vertex or a coordinate that is
    not finite.  The corners' vertices go straight into the ``.corner_vert`` attribute where Blender has it
    (twice as fast as through ``loops``).  :func:`mesh_without_edges` and :func:`finish_mesh` are its two
    halves, for a caller that gives Blender's interface a turn in between (about 27 and 35 ms of a 280,000-
    triangle mesh).
    """
    mesh, suspect = mesh_without_edges(name, verts, faces)
    finish_mesh(mesh, suspect)
    return mesh


def mesh_without_edges(name, verts, faces):
    """The first half of :func:`new_mesh_from_arrays`: the mesh's vertices and triangles, its edges not made yet
    -> (mesh, whether it needs Blender's validation).  Only :func:`finish_mesh` makes it a mesh to use."""
    verts = np.ascontiguousarray(verts, dtype=np.float32).reshape(-1, 3)
    faces = np.ascontiguousarray(faces, dtype=np.int32).reshape(-1, 3)
    if len(verts) == 0 or len(faces) == 0:
        raise ValueError("empty mesh")
    if faces.min() < 0 or faces.max() >= len(verts):
        raise ValueError("face index out of range")
    suspect = bool((faces[:, 0] == faces[:, 1]).any() or (faces[:, 1] == faces[:, 2]).any()
                   or (faces[:, 2] == faces[:, 0]).any() or not np.isfinite(verts).all())
    mesh = bpy.data.meshes.new(name)
    try:
        mesh.vertices.add(len(verts))
        mesh.vertices.foreach_set("co", verts.ravel())
        mesh.loops.add(faces.size)
        mesh.polygons.add(len(faces))
        corner_vert = mesh.attributes.get(".corner_vert")
        if corner_vert is not None and corner_vert.domain == 'CORNER' and corner_vert.data_type == 'INT':
            corner_vert.data.foreach_set("value", faces.ravel())
        else:
            mesh.loops.foreach_set("vertex_index", faces.ravel())
        mesh.polygons.foreach_set("loop_start", np.arange(0, faces.size, 3, dtype=np.int32))
    except Exception:
        bpy.data.meshes.remove(mesh)
        raise
    return mesh, suspect


def finish_mesh(mesh, suspect):
    """The second half of :func:`new_mesh_from_arrays`: the edges, and Blender's validation where needed.  The
    mesh is removed if it fails."""
    try:
        mesh.update(calc_edges=True)
        if suspect:
            mesh.validate(clean_customdata=False)
    except Exception:
        bpy.data.meshes.remove(mesh)
        raise


def edge_mesh(name, chains):
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


def point_mesh(name, points):
    """Mesh of loose vertices (a point cloud)."""
    mesh = bpy.data.meshes.new(name)
    try:
        mesh.vertices.add(len(points))
        mesh.vertices.foreach_set("co", np.ascontiguousarray(points, dtype=np.float32).ravel())
        mesh.update()
    except Exception:
        bpy.data.meshes.remove(mesh)
        raise
    return mesh


def mesh_world_arrays(obj):
    """World-space vertices (N,3 float64) and triangles (M,3 int) of a mesh object's base mesh.

    Analysis results are therefore stored in world coordinates (axis, v0 in scene units, to_world).
    """
    co, tris = mesh_local_arrays(obj)
    return placed(co, obj.matrix_world), tris


def mesh_local_arrays(obj):
    """The base mesh's vertices in its own frame (N,3 float64) and its triangles (M,3 int)."""
    co = mesh_vertices(obj.data)
    return co, mesh_triangles(obj.data, co=co)


def placed(co, matrix):
    """Vertices (N, 3) moved by the 4 x 4 ``matrix`` (as :func:`mesh_world_arrays` places them)."""
    mw = np.array(matrix, dtype=np.float64)
    return co @ mw[:3, :3].T + mw[:3, 3]


def mesh_vertices(mesh):
    """(N, 3) float64 vertex coordinates of a mesh.  Read in Blender's own single precision and widened by numpy:
    the same numbers as asking Blender for doubles, which converts one by one (0.3 ms instead of 16 ms for
    140,000 vertices)."""
    co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    attr = mesh.attributes.get("position")
    if attr is not None and attr.data_type == 'FLOAT_VECTOR' and attr.domain == 'POINT':
        attr.data.foreach_get("vector", co)
    else:
        mesh.vertices.foreach_get("co", co)
    return co.astype(np.float64).reshape(-1, 3)


def mesh_triangles(mesh, with_faces=False, co=None):
    """(M, 3) int32 vertex indices of the mesh's triangles, Blender's triangulation (``loop_triangles``), and with
    ``with_faces`` also (M,) int32 the face of each.  ``co``: the mesh's vertices (:func:`mesh_vertices`) where the
    caller has read them already (a mesh with quads needs them).

    Reading ``loop_triangles`` item by item is slow (0.12-0.3 s for a million triangles), so it is the last
    resort.  Where every face is a triangle, the triangles are each face's corners in order, read from the
    corners' vertex attribute at once (0.7 ms instead of 32 ms for 280,000 triangles).  Where every face is a
    triangle or a quad, Blender's own split of each quad is made here (:func:`tris_and_quads`); the few quads
    whose split lies within rounding of Blender's test are read from Blender one by one."""
    n_corners, n_faces = len(mesh.loops), len(mesh.polygons)
    corner_vert = mesh.attributes.get(".corner_vert")
    if corner_vert is not None and (corner_vert.domain != 'CORNER' or corner_vert.data_type != 'INT'):
        corner_vert = None
    if n_faces and n_corners == 3 * n_faces and corner_vert is not None:
        tris = np.empty(n_corners, dtype=np.int32)
        corner_vert.data.foreach_get("value", tris)
        tris = tris.reshape(-1, 3)
        return (tris, np.arange(n_faces, dtype=np.int32)) if with_faces else tris
    mesh.calc_loop_triangles()
    n_tris = len(mesh.loop_triangles)
    faces = None
    if hasattr(mesh, "loop_triangle_polygons"):           # a raw array: 1 ms for a million triangles
        faces = np.empty(n_tris, dtype=np.int32)
        mesh.loop_triangle_polygons.foreach_get("value", faces)
    if faces is not None and corner_vert is not None and n_tris == n_corners - 2 * n_faces:
        sizes = np.bincount(faces, minlength=n_faces) + 2       # a face of k corners makes k - 2 triangles
        if len(sizes) == n_faces and sizes.max(initial=3) <= 4:
            corners = np.empty(n_corners, dtype=np.int32)
            corner_vert.data.foreach_get("value", corners)
            tris, unsure, first = tris_and_quads(corners, sizes, mesh_vertices(mesh) if co is None else co)
            if len(unsure) <= MAX_UNSURE_QUADS:
                lt = mesh.loop_triangles
                for k in first[unsure].tolist():         # Blender's own split where rounding decides it
                    tris[k], tris[k + 1] = lt[k].vertices, lt[k + 1].vertices
                return (tris, faces) if with_faces else tris
    tris = np.empty(n_tris * 3, dtype=np.int32)
    mesh.loop_triangles.foreach_get("vertices", tris)
    tris = tris.reshape(-1, 3)
    if not with_faces:
        return tris
    if faces is None:
        faces = np.empty(n_tris, dtype=np.int32)
        mesh.loop_triangles.foreach_get("polygon_index", faces)
    return tris, faces


MAX_UNSURE_QUADS = 5000      # above this many quads to read one by one (each a few µs), read all triangles


def tris_and_quads(corners, sizes, co):
    """Blender's triangulation of a mesh of triangles and quads: ``corners`` every face's corner vertices in face
    order, ``sizes`` each face's corner count (3 or 4), ``co`` (n, 3) the vertex positions -> (triangles (M, 3)
    int32 in Blender's order, the quads whose split rounding may decide, each face's first triangle).

    A triangle stays as it is.  A quad (0, 1, 2, 3) is split along its diagonal 0-2 into (0, 1, 2), (0, 2, 3),
    unless Blender finds corners 1 and 3 on the same side of that diagonal (:func:`quad_flips`); then it is split
    along 1-3 into (0, 1, 3), (1, 2, 3).  That is Blender's tessellation of a mesh's quads whether or not its
    face normals were computed before (``mesh_tessellate.cc``; face normals only steer the split of larger
    faces).  A quad whose test lies within rounding of its threshold is returned as unsure (the caller asks
    Blender)."""
    sizes = np.asarray(sizes, dtype=np.int64)
    corners = np.asarray(corners)
    n_faces = len(sizes)
    first = 2 * np.arange(n_faces, dtype=np.int64)
    if n_faces and (sizes == 4).all():                     # a grid of quads: no offsets to find
        q, c = np.arange(n_faces), corners.reshape(-1, 4)
        tris = np.empty((2 * n_faces, 3), dtype=np.int32)
    else:
        start = np.zeros(n_faces, dtype=np.int64)
        np.cumsum(sizes[:-1], out=start[1:])
        first = start - first                              # a face of k corners comes after k - 2 triangles
        tris = np.empty((int(sizes.sum()) - 2 * n_faces, 3), dtype=np.int32)
        t = np.flatnonzero(sizes == 3)
        tris[first[t]] = corners[start[t, None] + np.arange(3)]
        q = np.flatnonzero(sizes == 4)
        c = corners[start[q, None] + np.arange(4)]
    if not len(q):
        return tris, q, first
    flip, unsure = quad_flips(co, c)
    one, two = first[q], first[q] + 1
    tris[one, :2] = c[:, :2]
    tris[one, 2] = np.where(flip, c[:, 3], c[:, 2])
    tris[two, 0] = np.where(flip, c[:, 1], c[:, 0])
    tris[two, 1:] = c[:, 2:]
    return tris, q[unsure], first


def quad_flips(co, quads, rel=1e-5):
    """Blender's choice of diagonal for the quads ``quads`` (q, 4) of vertex indices into ``co`` (n, 3) -> (flip:
    split along corners 1-3, unsure), each (q,).

    Blender flips where the triangles (0, 1, 2) and (0, 3, 2) face the same way: the dot product of
    d1 x d2 and d3 x d2, with di the edge from corner 0 to corner i, is positive
    (``is_quad_flip_v3_first_third_fast``, in single precision).  Here it is in double precision, as
    (d1 . d3)(d2 . d2) - (d1 . d2)(d3 . d2) (Binet-Cauchy), so a quad whose product lies within ``rel`` of
    |d1| |d2|^2 |d3| (about 170 units of single precision's last place) is unsure."""
    cols = np.ascontiguousarray(np.asarray(quads).T)             # (4, q): one gather per coordinate
    d = []
    for axis in range(3):
        x = np.ascontiguousarray(co[:, axis], dtype=np.float64)[cols]
        d.append(x[1:] - x[0])                                   # (3, q): d1, d2, d3 along this axis

    def dot(i, j):
        return d[0][i] * d[0][j] + d[1][i] * d[1][j] + d[2][i] * d[2][j]

    d22 = dot(1, 1)
    side = dot(0, 2) * d22 - dot(0, 1) * dot(2, 1)
    bound = rel * np.sqrt(dot(0, 0) * dot(2, 2)) * d22
    return side > bound, np.abs(side) <= bound


# ---------------------------------------------------------------------------------------------- attributes
def set_float_attr(mesh, name, values, domain='POINT'):
    """(Re)create a FLOAT attribute ``name`` with ``values``."""
    old = mesh.attributes.get(name)
    if old is not None:
        mesh.attributes.remove(old)
    attr = mesh.attributes.new(name, 'FLOAT', domain)
    attr.data.foreach_set("value", np.ascontiguousarray(values, dtype=np.float32))
    return attr


def set_int_attr(mesh, name, values, domain='POINT'):
    """(Re)create an INT attribute ``name`` with ``values``."""
    old = mesh.attributes.get(name)
    if old is not None:
        mesh.attributes.remove(old)
    attr = mesh.attributes.new(name, 'INT', domain)
    attr.data.foreach_set("value", np.ascontiguousarray(values, dtype=np.int32))
    return attr


def set_color_attr(mesh, name, rgba):
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


def remove_attributes(mesh, names):
    for name in names:
        attr = mesh.attributes.get(name)
        if attr is not None:
            mesh.attributes.remove(attr)


def clear_flank_props(obj, keys=PROP_KEYS):
    for key in keys:
        if key in obj:
            del obj[key]


def clear_prefixed(idb, prefix):
    """Delete every custom property of ``idb`` whose name starts with ``prefix``."""
    for key in [k for k in idb.keys() if k.startswith(prefix)]:
        del idb[key]


# ---------------------------------------------------------------------------------------------- objects
def select_only(context, obj):
    for other in context.view_layer.objects:
        if other.select_get():
            other.select_set(False)
    obj.select_set(True)
    context.view_layer.objects.active = obj


def select_if_visible(context, obj):
    """select_only, unless ``obj`` is not in the view layer (e.g. its collection is excluded)."""
    try:
        select_only(context, obj)
    except RuntimeError:
        pass


def remove_ids(objects=(), meshes=(), collections=(), actions=()):
    """Best-effort removal of data created by a failed operator (objects first)."""
    for ids, blocks in ((objects, bpy.data.objects), (meshes, bpy.data.meshes),
                        (collections, bpy.data.collections), (actions, bpy.data.actions)):
        for block in ids:
            try:
                blocks.remove(block)
            except (ReferenceError, RuntimeError):
                pass


def remove_objects(objs):
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


def remove_files(paths):
    import os

    for p in paths:
        try:
            os.remove(p)
        except OSError:
            pass


# ---------------------------------------------------------------------------------------------- animation
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


def linear_keys(obj):
    """Make every key of ``obj``'s action LINEAR; returns the action (None if it has none)."""
    ad = obj.animation_data
    if ad is None or ad.action is None:
        return None
    for fcu in iter_fcurves(ad.action):
        for kp in fcu.keyframe_points:
            kp.interpolation = 'LINEAR'
    return ad.action


def key_screw_motion(motion, keys, v0, eps):
    """LINEAR keys of the screw motion on an object about its parent's z axis: ``keys`` is
    [(frame, t), ...] (turn eps t, advance v0 t).  Returns the action (None if none was made)."""
    for f, t in keys:
        motion.location = (0.0, 0.0, v0 * t)
        motion.rotation_euler = (0.0, 0.0, eps * t)
        motion.keyframe_insert(data_path="location", index=2, frame=f)
        motion.keyframe_insert(data_path="rotation_euler", index=2, frame=f)
    return linear_keys(motion)


classes = ()
register, unregister = bpy.utils.register_classes_factory(classes)


def hide_objects(objs):
    """Hide the objects an animation stands in for (shown again when the animation is removed) -> their names."""
    hid = []
    for ob in objs:
        try:
            if not ob.hide_get():
                ob.hide_set(True)
                hid.append(ob.name)
        except RuntimeError:                 # not in the current view layer: nothing to hide
            pass
    return hid


# a relative path would land in Blender's working folder, wherever that is
RELATIVE = ("'{}' is a relative path: give an absolute path, or one starting with // (relative to the .blend "
            "file, once it is saved)")


def check_filepath(filepath, what="program file"):
    """(absolute path, None) or (None, error message) for a file an operator will write at ``filepath`` (a
    Blender path, '//' relative to the saved .blend): never the current folder by accident."""
    if not str(filepath).strip():
        return None, "no {} given (filepath is empty)".format(what)
    path = bpy.path.abspath(filepath)
    if not os.path.isabs(path):
        return None, RELATIVE.format(filepath)
    path = os.path.normpath(path)
    msg = output_path_error(path)
    return (None, msg) if msg else (path, None)


def output_file_error(path, what):
    """Why a file a run will write cannot be written at ``path`` (a Blender path, '//' relative), said before any
    work: a relative path without a saved .blend (it would land in Blender's working folder), its folder does
    not exist, or the path is a folder -> message, or None (also for an empty path)."""
    if not path:
        return None
    full = bpy.path.abspath(path)
    if not os.path.isabs(full):
        return "{} {}".format(what, RELATIVE.format(path))
    msg = output_path_error(full)
    return "{} {}: {}".format(what, full, msg) if msg else None
