# SPDX-License-Identifier: GPL-3.0-or-later
"""Small helpers shared by the operators (bpy only; numpy passed in)."""

# Object custom properties written by the operators.
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
