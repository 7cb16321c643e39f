# SPDX-License-Identifier: GPL-3.0-or-later
"""The one shared material of the result objects ("Flank Attribute Colour": the mesh's render colour attribute in
Material Preview, Rendered and Cycles) and the switch of Solid viewports to attribute colours."""
import bpy

ATTRIBUTE_MATERIAL = "Flank Attribute Colour"
ATTRIBUTE_MATERIAL_PROP = "flank_attribute_material"   # marks the material made here (found again if renamed)


def _find_attribute_material():
    for mat in bpy.data.materials:
        if mat.get(ATTRIBUTE_MATERIAL_PROP) is not None and mat.library is None:
            return mat
    return None


def _build_node_tree(mat):
    """Color Attribute (no name = the render colour) -> Principled BSDF base and emission colour -> output."""
    if getattr(mat, "node_tree", None) is None or bpy.app.version < (5, 0, 0):
        mat.use_nodes = True                 # Blender 4.x; 5.x materials always have a node tree
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    out.location = (300.0, 0.0)
    bsdf = nt.nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.location = (0.0, 0.0)
    col = nt.nodes.new("ShaderNodeVertexColor")
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


def attribute_material():
    """The one shared material of the result objects -> (material, created).  A created material has no users
    yet: the caller assigns it (:func:`assign_attribute_material`) or removes it again
    (:func:`release_attribute_material`)."""
    mat = _find_attribute_material()
    if mat is not None:
        return mat, False
    mat = bpy.data.materials.new(ATTRIBUTE_MATERIAL)
    try:
        _build_node_tree(mat)
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


def release_attribute_material(mat=None):
    """Remove the shared attribute material when nothing uses it any more (no orphan data is left)."""
    if mat is None:
        mat = _find_attribute_material()
    try:
        if mat is not None and mat.users == 0:
            bpy.data.materials.remove(mat)
    except ReferenceError:
        pass


class RunMaterial:
    """The shared attribute material for one run, fetched or made on first use: ``assign(mesh)`` puts it on a
    result mesh; ``discard()`` (a failed run, after its meshes are removed) removes it again if this run made
    it, so nothing is left behind."""

    def __init__(self):
        self.mat, self.created = None, False

    def assign(self, mesh, only_if_none=False):
        if self.mat is None:
            self.mat, self.created = attribute_material()
        return assign_attribute_material(mesh, self.mat, only_if_none)

    def discard(self):
        if self.created and self.mat is not None:
            release_attribute_material(self.mat)
        self.mat, self.created = None, False


_SHADING_SWITCHED = set()     # View3D shading settings switched to Attribute colours once (never again)


def _view3d_shadings(context):
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
                shading = getattr(space, "shading", None) if space.type == 'VIEW_3D' else None
                if shading is not None:
                    yield shading


def show_attribute_colors(context):
    """After a successful run: 3D Viewports in Solid mode colouring by Material (the default) switch to
    Attribute colours once each, so the strips' error colours show.  Nothing happens in background mode, and
    a viewport the user switched back keeps the user's choice."""
    if bpy.app.background:
        return 0
    switched = 0
    for shading in _view3d_shadings(context):
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


classes = ()
register, unregister = bpy.utils.register_classes_factory(classes)
