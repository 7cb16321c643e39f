# SPDX-License-Identifier: GPL-3.0-or-later
"""The one builder of a planning run's results in the scene, shared by every planner.

A run is a collection under "Flank Results" (replacing the collection of an earlier run with the same key,
only once the new one is complete) holding the run's objects: tools, envelope strips coloured by their signed
error through the shared material "Flank Attribute Colour", error charts, an animated tool motion; the files
it wrote; the custom properties that describe it.  :meth:`RunBuilder.build` makes all of it or nothing: on any
error every object, mesh, action, collection, material and file made so far is removed again and the error is
reported (no traceback, no half-built data).

    run = RunBuilder(context, "flank_sf_", key, "Single Flank (rotor, flank 1)", owner=("rotor", rotor.name))
    replaced = run.build(operator, "single-flank results", lambda: fill(run))
    if replaced is None:
        return {'CANCELLED'}
    run.store(props, [run.collection, rotor, *tools], clear=[rotor])
    run.show(tools[0])
"""
import bpy
import numpy as np
from mathutils import Matrix

from .common import (edge_mesh, key_screw_motion, new_mesh_from_arrays, remove_files, remove_ids,
                     select_if_visible, set_color_attr, set_float_attr)
from .materials import RunMaterial, show_attribute_colors
from .runs import results_parent, replace_run

DEVIATION_ATTR = "deviation"            # FLOAT point attribute of the envelope strips (scene units, + = stock)
DEVIATION_COLOR_ATTR = "error_color"    # FLOAT_COLOR of the envelope strips (verify.deviation_colors)
COLOR_TOOL = (0.90, 0.72, 0.20, 1.0)
COLOR_ENVELOPE = (0.55, 0.62, 0.70, 1.0)
COLOR_CHART = (0.10, 0.10, 0.10, 1.0)


def finite_runs(mask):
    """[(start, stop)] of the runs of True in a boolean array (stop exclusive)."""
    m = np.r_[False, np.asarray(mask, dtype=bool), False]
    d = np.diff(m.astype(np.int8))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


class RunBuilder:
    """One planning run's result collection, built all or nothing (see the module's documentation).

    ``prefix``: the planner's custom property prefix (``flank_sf_`` ...); the collection's key is stored as
    ``prefix + "key"`` (or ``key_prop``); ``owner`` = (property, value) written on every object (the rotor or
    surface it was made from); ``index_key``: the property numbering strips / paths."""

    def __init__(self, context, prefix, key, name, owner=None, index_key="strip", key_prop=None):
        self.context, self.prefix, self.key, self.name = context, prefix, key, name
        self.owner, self.index_key = owner, index_key
        self.key_prop = key_prop or prefix + "key"
        self.collection = self.parent = None
        self.parent_created = False
        self.objects, self.meshes, self.actions, self.files, self.names = [], [], [], [], []
        self.material = RunMaterial()
        self._undo = []

    # ------------------------------------------------------------------ all or nothing
    def build(self, operator, what, fill):
        """Make the run's collection, call ``fill()`` to add its contents, then replace earlier runs of the same
        key.  Returns the number of runs replaced, or None after an error (reported, everything removed)."""
        try:
            self.parent, self.parent_created = results_parent(self.context)
            self.collection = bpy.data.collections.new(self.name + " new")
            self.parent.children.link(self.collection)
            fill()
            return replace_run(self.parent, self.collection, self.key_prop, self.key, self.name, self.names)
        except Exception as ex:
            self.discard()
            operator.report({'ERROR'}, "Could not build the {}: {}: {}".format(what, type(ex).__name__, ex))
            return None

    def discard(self):
        """Remove everything this run made (also undoing its changes to objects it did not make)."""
        for undo in reversed(self._undo):
            try:
                undo()
            except (ReferenceError, RuntimeError):
                pass
        colls = [self.collection] if self.collection is not None else []
        if self.parent_created:
            colls.append(self.parent)
        remove_ids(self.objects, self.meshes, colls, self.actions)
        self.material.discard()
        remove_files(self.files)

    def on_failure(self, undo):
        """Call ``undo()`` when the run fails (e.g. to remove attributes written on the user's rotor)."""
        self._undo.append(undo)

    # ------------------------------------------------------------------ data blocks
    def own_mesh(self, mesh, name=None):
        """Register a mesh made for this run (removed on failure, named ``name`` once the run is complete)."""
        if mesh is not None and mesh not in self.meshes:
            self.meshes.append(mesh)
            self.names.append((mesh, name or mesh.name))
        return mesh

    def mesh(self, name, verts, faces):
        return self.own_mesh(new_mesh_from_arrays(name, verts, faces), name)

    def edges(self, name, chains):
        return self.own_mesh(edge_mesh(name, chains), name)

    def add(self, name, data=None, color=None, role=None, index=None, matrix=None):
        """A new object of the run (``data`` None: an empty) with the owner, role and strip index properties."""
        if data is not None and data not in self.meshes and isinstance(data, bpy.types.Mesh):
            self.own_mesh(data, name)
        ob = bpy.data.objects.new(name, data)
        self.objects.append(ob)
        self.names.append((ob, name))
        if color is not None:
            ob.color = color
        self.collection.objects.link(ob)
        if self.owner is not None:
            ob[self.prefix + self.owner[0]] = self.owner[1]
        if role is not None:
            ob[self.prefix + "role"] = role
        if index is not None:
            ob[self.prefix + self.index_key] = int(index)
        if matrix is not None:
            ob.matrix_world = Matrix(np.asarray(matrix, dtype=np.float64).tolist())
        return ob

    def add_mesh(self, name, verts, faces, color=None, role=None, index=None, matrix=None):
        return self.add(name, self.mesh(name, verts, faces), color, role, index, matrix)

    def color_by_attribute(self, mesh, only_if_none=False):
        """Show the mesh's colour attribute through the shared material; True when the mesh was changed."""
        return self.material.assign(mesh, only_if_none)

    def add_strip(self, name, verts, faces, deviation, tolerance, matrix, index=None, stored=None):
        """An envelope strip: ``deviation`` (signed, scene units) as the FLOAT point attribute ``deviation`` (the
        values ``stored`` if given) and its colours (verify.deviation_colors) as ``error_color``."""
        from ..flank_addon.simulation.verify import deviation_colors

        ob = self.add_mesh(name, verts, faces, COLOR_ENVELOPE, "envelope", index, matrix)
        me = ob.data
        set_float_attr(me, DEVIATION_ATTR, deviation if stored is None else stored)
        set_color_attr(me, DEVIATION_COLOR_ATTR, deviation_colors(deviation, tolerance))
        self.color_by_attribute(me)
        me.update()
        return ob

    # ------------------------------------------------------------------ motion and files
    def add_motion(self, name, parent, keys, v0, eps, size, frame=None, role="motion"):
        """An empty parented to the rotor ``parent`` with LINEAR keys of the screw motion about the rotor axis
        (``keys`` = [(frame, t)]); ``frame``: the rotor frame in world coordinates when it is not the parent's
        own (an analysed mesh's ``to_world``)."""
        motion = self.add(name, None, role=role)
        motion.empty_display_type = 'ARROWS'
        motion.empty_display_size = size
        motion.parent = parent
        if frame is not None:
            motion.matrix_parent_inverse = parent.matrix_world.inverted() @ Matrix(np.asarray(frame).tolist())
        else:
            motion.matrix_parent_inverse = Matrix.Identity(4)
        motion.matrix_basis = Matrix.Identity(4)
        action = key_screw_motion(motion, keys, v0, eps)
        if action is not None:
            self.actions.append(action)
        return motion

    def add_moving(self, name, motion, mesh, basis, color=COLOR_TOOL, index=None, role="moving"):
        """A copy of a tool (sharing its mesh) riding on the motion empty at ``basis`` (rotor frame)."""
        ob = self.add(name, mesh, color, role, index)
        ob.parent = motion
        ob.matrix_parent_inverse = Matrix.Identity(4)
        ob.matrix_basis = Matrix(np.asarray(basis, dtype=np.float64).tolist())
        return ob

    def own_action(self, action):
        if action is not None and action not in self.actions:
            self.actions.append(action)

    def write(self, path, writer):
        """Write a file of the run (``writer(path)``); it is removed again if the run fails."""
        self.files.append(path)
        writer(path)
        return path

    # ------------------------------------------------------------------ after a successful build
    def store(self, props, targets, clear=()):
        """Write ``props`` as ``prefix + name`` custom properties on every target, after removing the prefix's
        earlier properties from the objects in ``clear`` (e.g. the rotor of an earlier run)."""
        for idb in clear:
            for key in [k for k in idb.keys() if k.startswith(self.prefix)]:
                del idb[key]
        for target in targets:
            for name, value in props.items():
                target[self.prefix + name] = value

    def show(self, obj):
        """Select the run's main object and let Solid viewports show the attribute colours."""
        if obj is not None:
            select_if_visible(self.context, obj)
        show_attribute_colors(self.context)


classes = ()
register, unregister = bpy.utils.register_classes_factory(classes)
