# SPDX-License-Identifier: GPL-3.0-or-later
"""A machine program in the scene: the tool tip's path relative to the rotor as an edge mesh in the run's
collection (INT edge attributes ``motion``: 1 cutting, 0 rapid or link; ``pass``: the pass number of a cutting
edge, 0 for links), and the program's animation -- a linked copy of the rotor turning about its own axis while
a tool moves so that, relative to the rotor, the tool is where the program puts it (``program`` explains the
frames).  All made at once or not at all: :class:`ProgramBuild` removes what it made when anything fails.

Objects (in the run's collection):

- ``<run>: Program`` (role ``path``), the path in the rotor frame in mm, placed by the plan's rotor frame scaled
  by 1 / k (k = mm per plan length unit);
- ``<run>: Holders`` (role ``holders``) when the program was posted with holders: their cylinders, placed as
  the path (they are round about the rotor axis, so they stand still while the rotor copy turns);
- ``<run>: Checked Program`` (role ``checked``): the path of the program file the latest Check Program File read
  back, placed as the posted one (flank.check_program; posting again leaves it);
- with the animation (the run's animation, like flank.animate_strip's: replacing it, hiding the rotor and the
  path while it exists, removed with flank.animate_strip's next run or the run): the rotor frame (an empty), the
  spin (an empty keyed by psi about the rotor axis), a linked copy of the rotor and of the path riding on the
  spin, and per tool a tool mesh keyed in location and rotation (quaternion)."""
import bpy
import numpy as np
from mathutils import Matrix

from .common import iter_fcurves, remove_ids, set_int_attr
from .runs import ANIM_HID, ANIM_ROLE
from .shapes import revolved_mesh

PROG_PREFIX = "flank_prog_"          # custom properties of the program on the run's collection and objects
PROG_ROLE = PROG_PREFIX + "role"     # "path" on the program's path object
MOTION_ATTR = "motion"               # INT edge attribute: 1 cutting, 0 rapid / link
PASS_ATTR = "pass"                   # INT edge attribute: pass number (1..) of a cutting edge, 0 on links
COLOR_PATH = (0.85, 0.35, 0.10, 1.0)
COLOR_CHECKED = (0.15, 0.45, 0.85, 1.0)
COLOR_TOOL = (0.90, 0.72, 0.20, 1.0)
COLOR_HOLDER = (0.45, 0.47, 0.50, 1.0)
TOOL_SEGMENTS = 32
HOLDER_SEGMENTS = 48


def _linear_value():
    return bpy.types.Keyframe.bl_rna.properties["interpolation"].enum_items["LINEAR"].value


def key_channels(obj, data_path, frames, values, indices):
    """LINEAR keys of ``obj.<data_path>[i]`` for i in ``indices`` at ``frames`` (K,, increasing) with ``values``
    (K, n), written in one go (foreach_set) -> the action.  Handles sit on their keys.  ``FCurve.update`` is not
    called: it merges keys less than 0.01 frames apart, and a short rapid between two passes can take less."""
    frames = np.asarray(frames, float)
    values = np.asarray(values, float).reshape(len(frames), -1)
    for i in indices:
        obj.keyframe_insert(data_path=data_path, index=i, frame=float(frames[0]))
    action = obj.animation_data.action
    lin = _linear_value()
    for fc in iter_fcurves(action):
        if fc.data_path != data_path or fc.array_index not in indices:
            continue
        kp = fc.keyframe_points
        kp.add(len(frames) - len(kp))
        co = np.empty(2 * len(frames), dtype=np.float32)
        co[0::2], co[1::2] = frames, values[:, fc.array_index]
        for name in ("co", "handle_left", "handle_right"):
            kp.foreach_set(name, co)
        kp.foreach_set("interpolation", np.full(len(frames), lin, dtype=np.int32))
    return action


def strictly_increasing(frames):
    """Indices keeping the last of equal frames (a key time may repeat where a move takes no time)."""
    f = np.asarray(frames, float)
    return np.flatnonzero(np.r_[f[1:] > f[:-1], True])


def _quaternions(axes):
    """Unit quaternions (w, x, y, z) (K, 4) turning +z onto the unit axes (K, 3), signs kept continuous."""
    from mathutils import Vector

    q = np.array([list(Vector(a.tolist()).to_track_quat('Z', 'Y')) for a in np.asarray(axes, float)], float)
    for k in range(1, len(q)):
        if q[k] @ q[k - 1] < 0.0:
            q[k] = -q[k]
    return q


class ProgramBuild:
    """The objects, meshes and actions of one posting, removed again by :meth:`discard`."""

    def __init__(self, coll, name):
        self.coll, self.name = coll, name
        self.objects, self.meshes, self.actions = [], [], []
        self.roles = []                      # (object, animation role): set once the run's old animation is gone

    def add(self, name, data=None, parent=None):
        if isinstance(data, bpy.types.Mesh) and data not in self.meshes and data.users == 0:
            self.meshes.append(data)
        ob = bpy.data.objects.new(name, data)
        self.objects.append(ob)
        self.coll.objects.link(ob)
        if parent is not None:
            ob.parent = parent
            ob.matrix_parent_inverse = Matrix.Identity(4)
        return ob

    def own_action(self, obj):
        ad = obj.animation_data
        if ad is not None and ad.action is not None and ad.action not in self.actions:
            self.actions.append(ad.action)

    def discard(self):
        remove_ids(self.objects, self.meshes, (), self.actions)
        self.objects, self.meshes, self.actions, self.roles = [], [], [], []

    def mark_animation(self, hidden):
        """Make the new animation the run's (after its earlier one was removed): roles, and on the spin the
        names of the objects it hides."""
        for ob, role in self.roles:
            ob[ANIM_ROLE] = role
            if role == "spin":
                ob[ANIM_HID] = hidden

    # ------------------------------------------------------------------ the path
    def path(self, path, matrix, label="Program", role="path", color=COLOR_PATH):
        """The path object (edges, motion and pass attributes) at ``matrix`` (rotor frame mm -> world), named
        ``<run>: <label>`` with ``role``."""
        pts = np.ascontiguousarray(path["points"], dtype=np.float32)
        edges = np.ascontiguousarray(path["edges"], dtype=np.int32)
        if not len(edges):
            raise ValueError("the program has no moves to draw")
        me = bpy.data.meshes.new("{}: {}".format(self.name, label))
        self.meshes.append(me)
        me.vertices.add(len(pts))
        me.vertices.foreach_set("co", pts.ravel())
        me.edges.add(len(edges))
        me.edges.foreach_set("vertices", edges.ravel())
        me.update()
        set_int_attr(me, MOTION_ATTR, path["motion"], domain='EDGE')
        set_int_attr(me, PASS_ATTR, path["passes"], domain='EDGE')
        ob = self.add(me.name, me)
        ob.matrix_world = Matrix(np.asarray(matrix, float).tolist())
        ob.color = color
        ob[PROG_ROLE] = role
        return ob

    # ------------------------------------------------------------------ the holders
    def holders(self, holders, matrix):
        """The holders (chuck, tailstock: coaxial cylinders [(z_a, z_b, radius)] in the rotor frame, mm) as one
        mesh at ``matrix`` (rotor frame mm -> world), or None without holders."""
        if not holders:
            return None
        verts, faces = [], []
        for a, b, r in holders:
            v, f = revolved_mesh(np.array([[0.0, b], [r, b], [r, a], [0.0, a]]), HOLDER_SEGMENTS)
            faces.append(np.asarray(f) + sum(len(x) for x in verts))
            verts.append(np.asarray(v))
        me = bpy.data.meshes.new(self.name + ": Holders")
        self.meshes.append(me)
        me.from_pydata(np.concatenate(verts).tolist(), [], np.concatenate(faces).tolist())
        me.update()
        ob = self.add(self.name + ": Holders", me)
        ob.matrix_world = Matrix(np.asarray(matrix, float).tolist())
        ob.color = COLOR_HOLDER
        ob[PROG_ROLE] = "holders"
        return ob

    # ------------------------------------------------------------------ the animation
    def animation(self, keys, frames, matrix, rotor, path_ob, shapes, outline):
        """Frame and spin empties, the rotor and path copies on the spin, one keyed tool per tool number
        (``outline(shape)``: its (radius, height) outline) -> the spin empty."""
        frame = self.add(self.name + ": Program Frame")
        frame.empty_display_type = 'PLAIN_AXES'
        frame.matrix_world = Matrix(np.asarray(matrix, float).tolist())
        spin = self.add(self.name + ": Program Spin", parent=frame)
        spin.empty_display_type = 'ARROWS'
        keep = strictly_increasing(frames)
        key_channels(spin, "rotation_euler", frames[keep], np.c_[np.zeros((len(keep), 2)), keys["psi"][keep]], [2])
        self.own_action(spin)
        if rotor is not None:
            copy = self.add("{} (program)".format(rotor.name), rotor.data, parent=spin)
            copy.matrix_parent_inverse = Matrix(np.linalg.inv(np.asarray(matrix, float)).tolist())
            copy.matrix_basis = rotor.matrix_world.copy()
            copy.color = rotor.color
            self.roles.append((copy, "rotor"))
        moving = self.add(path_ob.name + " (moving)", path_ob.data, parent=spin)
        moving.color = COLOR_PATH
        for number, shape in sorted(shapes.items()):
            sel = np.flatnonzero(keys["tools"] == number)
            if not len(sel):
                continue
            sel = sel[strictly_increasing(frames[sel])]
            me = self.own_tool_mesh("{}: Program Tool T{}".format(self.name, number), outline(shape))
            tool = self.add(me.name, me, parent=frame)
            tool.color = COLOR_TOOL
            tool.rotation_mode = 'QUATERNION'
            key_channels(tool, "location", frames[sel], keys["tips"][sel], [0, 1, 2])
            key_channels(tool, "rotation_quaternion", frames[sel], _quaternions(keys["axes"][sel]), [0, 1, 2, 3])
            self.own_action(tool)
            tool[PROG_PREFIX + "tool"] = int(number)
            self.roles.append((tool, "tool"))
        self.roles += [(frame, "frame"), (spin, "spin"), (moving, "path")]
        return spin

    def own_tool_mesh(self, name, rh):
        verts, faces = revolved_mesh(rh, TOOL_SEGMENTS)
        me = bpy.data.meshes.new(name)
        self.meshes.append(me)
        me.from_pydata(verts.tolist(), [], faces.tolist())
        me.update()
        return me


def program_objects(coll):
    """The posted program's objects of a run (its path and holders), not its animation nor a checked program's
    path."""
    return [ob for ob in coll.objects if ob.get(PROG_ROLE) is not None and ob.get(PROG_ROLE) != "checked"]


def checked_objects(coll):
    """The path of the program file the latest Check Program File read back (at most one)."""
    return [ob for ob in coll.objects if ob.get(PROG_ROLE) == "checked"]


def store_program(coll, props):
    """Replace the run's program properties (``flank_prog_*`` on the collection)."""
    for key in [k for k in coll.keys() if k.startswith(PROG_PREFIX)]:
        del coll[key]
    for name, value in props.items():
        coll[PROG_PREFIX + name] = value


classes = ()
register, unregister = bpy.utils.register_classes_factory(classes)
