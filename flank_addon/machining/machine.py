"""Machine definitions (versioned JSON, schema "flank-machine/1") and their kinematics.

The file format is documented in docs/machine-file.md; the built-ins live in ``machines/*.json`` next to
this module.  Coordinates:

* *program coordinates* (the work offset): program zero is the rotor frame's origin; with every rotary
  axis at 0 a rotor-frame point p sits at W p, W = the file's ``rotor_mount`` (a rotation: the rotor's z
  and x axes named as machine directions, y = z x x);
* a table rotary axis i turns the workpiece about the line through its ``pivot`` (program coordinates at
  all rotaries 0) with unit ``direction`` d_i, by the right-hand rule: T_i(th)(w) = R(d_i, th)(w - c_i) + c_i.
  ``table_chain`` lists them from the machine base to the workpiece, so a workpiece point w is at
  M(th) w = T_1(th_1)(T_2(th_2)(... w)) in the machine;
* a head rotary axis turns the spindle about ``pivot`` + ``pivot_length`` * tool_axis (relative to the tool
  tip at all head angles 0; plus the tool's gauge length when ``tool_length_in_pivot``).  ``head_chain``
  lists them from the base to the spindle; the tool axis (tip -> shank) is R_h1 R_h2 ... ``tool_axis``,
  the tip is XYZ + H(th)(0) with H = T_h1(T_h2(...)) on the pivots;
* without TCP the program holds joint values: XYZ = M(th) W p_tip - H(th)(0);
  with TCP (``controller.tcp``) XYZ is the tool tip in program coordinates, W p_tip, and the controller
  does the rest (Fanuc G43.4, Heidenhain M128 / FUNCTION TCPM, LinuxCNC with a TCP kinematics module).

Inverse kinematics of a rotor pass (:meth:`Machine.orientations`): the innermost table axis must carry the
rotor on its own axis (the *spin* axis, direction sigma W e_z, sigma = +-1); the one other rotary axis (the
*tilt*, outer table axis or head axis) tilts the tool.  A rotor-frame tool axis a is reached where
R_tilt-side(...) R_spin(th_s) W a = R_head(...) tool_axis: with u = R_spin(th_s) W a the component along the
tilt direction is fixed (u . d_t = tool_axis . d_t), one equation p cos th_s + q sin th_s = c with two
solutions; the tilt angle then turns u onto the tool axis (table) or the tool axis onto u (head).  Of the two
the one with the smaller |tilt| inside the limits is taken, the spin turn nearest to a given angle
(spin axes are continuous: no wrap).

A rotor pass keeps the tilt and turns the spin by sigma * hand * t while the rotor-frame pose screws by
S_-t: then M(th) W S_-t(T) = M(th_0) W T - v0 t M W e_z and the axis is fixed, so every joint is linear in
t: one joint-linear block is the exact screw motion (:meth:`Machine.pass_joints`).
"""
import json
import math
import os
from dataclasses import dataclass, field

import numpy as np

SCHEMA = "flank-machine/1"
LINEAR = ("X", "Y", "Z")
ROTARY = ("A", "B", "C")
MACHINE_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "machines")
DIRECTIONS = {"+X": (1, 0, 0), "-X": (-1, 0, 0), "+Y": (0, 1, 0), "-Y": (0, -1, 0), "+Z": (0, 0, 1), "-Z": (0, 0, -1)}


class MachineError(ValueError):
    """A machine file breaks flank-machine/1 (the message names the key and value), an unknown machine
    (the message lists the valid names) or a pose the machine cannot reach (names the pass and axis)."""


def builtin_machines():
    """Names of the machine files shipped with the package."""
    return sorted(f[:-5] for f in os.listdir(MACHINE_DIR) if f.endswith(".json"))


def rotation(d, th):
    """Rotation matrices (..., 3, 3) about unit axis d by angles th (rad, broadcast), right-hand rule."""
    d = np.asarray(d, float)
    th = np.asarray(th, float)
    c, s = np.cos(th)[..., None, None], np.sin(th)[..., None, None]
    K = np.array([[0.0, -d[2], d[1]], [d[2], 0.0, -d[0]], [-d[1], d[0], 0.0]])
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def _num(v, key, lo=-math.inf, hi=math.inf, positive=False):
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise MachineError(f"{key} must be a finite number, got {v!r}")
    if positive and not v > 0:
        raise MachineError(f"{key} must be > 0, got {v!r}")
    if not lo <= v <= hi:
        raise MachineError(f"{key} = {v!r} is outside {lo:g}..{hi:g}")
    return float(v)


# the largest length (mm) and angle (deg) a machine file may give: a kilometre of travel or a pivot a
# kilometre off is a typing error, and values near the float range overflow in the kinematics
MAX_LENGTH_MM = 1e6
MAX_ANGLE_DEG = 1e9


def _vec(v, key, unit=False, bound=MAX_LENGTH_MM):
    if not (isinstance(v, list) and len(v) == 3):
        raise MachineError(f"{key} must be a list of 3 numbers, got {v!r}")
    a = np.array([_num(x, f"{key}[{i}]", -bound, bound) for i, x in enumerate(v)])
    if unit:
        n = float(np.linalg.norm(a))
        if not n > 0:
            raise MachineError(f"{key} must not be the zero vector")
        a = a / n
    return a


def _direction(v, key):
    if not isinstance(v, str) or v not in DIRECTIONS:
        raise MachineError(f"{key} must be one of {', '.join(DIRECTIONS)}, got {v!r}")
    return np.array(DIRECTIONS[v], float)


@dataclass
class Axis:
    name: str
    min: float
    max: float
    max_feed: float          # mm/min or deg/min
    rapid: float             # mm/min or deg/min
    on: str = "linear"       # "linear" | "table" | "head"
    direction: np.ndarray = None
    pivot: np.ndarray = None


@dataclass
class Machine:
    name: str
    description: str
    version: int
    tcp: bool
    axes: dict               # name -> Axis, X Y Z then the rotaries
    table_chain: list
    head_chain: list
    pivot_length: float
    tool_length_in_pivot: bool
    mount: np.ndarray        # 3x3: program coordinates of the rotor frame's x, y, z (columns)
    tool_axis: np.ndarray    # tool axis (tip -> shank) at all head angles 0
    max_rpm: float
    tool_change_s: float
    source: str = ""
    notes: list = field(default_factory=list)
    tool_change_position: dict = None   # joint values the tool-change cycle leaves (X, Y, Z; rotaries optional)
    reference_position: dict = None     # joint value a reference return (Fanuc G28) takes the retract axis to
    increment_mm: float = None          # the control's least input increment of lengths (None: the post's own)
    increment_deg: float = None         # ... of angles

    # ------------------------------------------------------------------ structure
    @property
    def rotary_names(self):
        return [n for n in ROTARY if n in self.axes]

    @property
    def axis_names(self):
        return list(LINEAR) + self.rotary_names

    @property
    def spin(self):
        return self.table_chain[-1]

    @property
    def tilt(self):
        return next(n for n in self.rotary_names if n != self.spin)

    @property
    def retract_axis(self):
        """(name, end of travel) of the linear axis along the tool axis at all head angles 0 (Z on a vertical
        machine), at the end the tool points to from its tip (``tool_axis``, tip -> shank): away from the work.
        A reference return (Fanuc G28) and, on most machines, the tool-change cycle lift the tool that way."""
        i = int(np.argmax(np.abs(self.tool_axis)))
        ax = self.axes[LINEAR[i]]
        return LINEAR[i], (ax.max if self.tool_axis[i] > 0 else ax.min)

    @property
    def spin_sign(self):
        """sigma: +1 when the spin axis points along the rotor's +z, -1 against it."""
        return 1.0 if float(self.axes[self.spin].direction @ self.mount[:, 2]) > 0 else -1.0

    def flipped(self):
        """The same machine with the rotor mounted the other way round (turned 180 deg about its x axis:
        z and y reversed), for tools whose axes point down the rotor's z."""
        import dataclasses

        m = dataclasses.replace(self, mount=self.mount * np.array([1.0, -1.0, -1.0]), name=self.name + " (rotor flipped)")
        return m

    def describe(self):
        return {"name": self.name, "version": self.version, "tcp": self.tcp, "axes": self.axis_names,
                "spin_axis": self.spin, "tilt_axis": self.tilt, "source": self.source}

    # ------------------------------------------------------------------ kinematics
    def _angles(self, joints):
        J = np.atleast_2d(np.asarray(joints, float))
        return {n: np.radians(J[:, 3 + i]) for i, n in enumerate(self.rotary_names)}, J[:, :3]

    def table_transform(self, ang):
        """(R (N, 3, 3), t (N, 3)) with machine = R w + t for workpiece points w, at rotary angles ``ang``."""
        N = len(next(iter(ang.values())))
        R = np.broadcast_to(np.eye(3), (N, 3, 3)).copy()
        t = np.zeros((N, 3))
        for name in reversed(self.table_chain):            # innermost first
            ax = self.axes[name]
            Ri = rotation(ax.direction, ang[name])
            R = Ri @ R
            t = np.einsum("nij,nj->ni", Ri, t - ax.pivot) + ax.pivot
        return R, t

    def head_transform(self, ang, tool_length=0.0):
        """(tip offset (N, 3) from the control point, tool axis (N, 3)) at rotary angles ``ang``."""
        N = len(next(iter(ang.values())))
        R = np.broadcast_to(np.eye(3), (N, 3, 3)).copy()
        off = np.zeros((N, 3))
        extra = (self.pivot_length + (tool_length if self.tool_length_in_pivot else 0.0)) * self.tool_axis
        for name in reversed(self.head_chain):             # spindle side first
            ax = self.axes[name]
            c = ax.pivot + extra
            Ri = rotation(ax.direction, ang[name])
            off = np.einsum("nij,nj->ni", Ri, off - c) + c
            R = Ri @ R
        return off, np.einsum("nij,j->ni", R, self.tool_axis)

    def forward(self, joints, tool_length=0.0, tcp=None):
        """Rotor-frame tool tip (N, 3) and unit axis (N, 3) of joint rows (N, axes) (program values;
        ``tcp=False``: joint values of a TCP machine)."""
        ang, xyz = self._angles(joints)
        R, t = self.table_transform(ang)
        off, axis_m = self.head_transform(ang, tool_length)
        if self.tcp if tcp is None else tcp:
            w_tip = xyz
        else:
            w_tip = np.einsum("nji,nj->ni", R, xyz + off - t)
        w_axis = np.einsum("nji,nj->ni", R, axis_m)
        return w_tip @ self.mount, w_axis @ self.mount

    def control_points(self, tips, angles_deg, tool_length=0.0, tcp=None):
        """Programmed XYZ (N, 3) putting the tool tip at rotor-frame points ``tips`` (N, 3) at the rotary
        angles (N, rotaries) in degrees; ``tcp=False`` gives the joint values of a TCP machine."""
        A = np.atleast_2d(np.asarray(angles_deg, float))
        w = np.atleast_2d(np.asarray(tips, float)) @ self.mount.T
        if self.tcp if tcp is None else tcp:
            return w
        ang = {n: np.radians(A[:, i]) for i, n in enumerate(self.rotary_names)}
        R, t = self.table_transform(ang)
        off, _ = self.head_transform(ang, tool_length)
        return np.einsum("nij,nj->ni", R, w) + t - off

    def orientations(self, axis):
        """Rotary angle pairs (radians, dict per solution) that put the rotor-frame unit axis on the spindle,
        best first (smaller |tilt| inside the limits); empty when the axis is unreachable."""
        b = self.mount @ np.asarray(axis, float)
        ds = self.axes[self.spin].direction
        tilt = self.axes[self.tilt]
        dt = tilt.direction
        e0 = self.tool_axis
        b_par = float(b @ ds)
        e1 = b - b_par * ds
        e2 = np.cross(ds, e1)
        p, q = float(e1 @ dt), float(e2 @ dt)
        c = float(e0 @ dt) - b_par * float(ds @ dt)
        amp = math.hypot(p, q)
        if amp < 1e-12:                                    # axis along the spin axis: spin is free
            spins = [0.0] if abs(c) < 1e-9 else []
        else:
            if abs(c) > amp * (1 + 1e-12):
                return []
            base, half = math.atan2(q, p), math.acos(max(-1.0, min(1.0, c / amp)))
            spins = [base + half, base - half] if half > 1e-12 else [base]
        out = []
        for th_s in spins:
            u = rotation(ds, th_s) @ b
            v1, v2 = (u, e0) if tilt.on == "table" else (e0, u)        # turn v1 onto v2 about dt
            a1, a2 = v1 - (v1 @ dt) * dt, v2 - (v2 @ dt) * dt
            th_t = math.atan2(float(dt @ np.cross(a1, a2)), float(a1 @ a2))
            out.append({self.spin: th_s, self.tilt: th_t})
        lim = lambda s: tilt.min <= math.degrees(s[self.tilt]) <= tilt.max  # noqa: E731
        return sorted(out, key=lambda s: (not lim(s), abs(s[self.tilt])))

    def pass_joints(self, tip, axis, hand, v0, t, near_spin_deg=0.0, tool_length=0.0):
        """Joint rows (len(t), axes) of a rotor pass: the rotor-frame pose (tip, axis) at t = 0 screwed by
        S_-t for the screw parameters t (rad).  Raises :class:`MachineError` when no tilt reaches the axis."""
        sols = self.orientations(axis)
        if not sols:
            raise MachineError(f"machine {self.name}: no {self.spin}/{self.tilt} setting turns the tool axis "
                               f"{np.round(axis, 6).tolist()} onto the spindle")
        sol = sols[0]
        t = np.asarray(t, float)
        sigma = self.spin_sign
        spin0 = math.degrees(sol[self.spin])
        spin_t0 = spin0 + sigma * hand * math.degrees(float(t[0]))
        spin0 += 360.0 * round((near_spin_deg - spin_t0) / 360.0)
        angles = np.zeros((len(t), len(self.rotary_names)))
        for i, n in enumerate(self.rotary_names):
            angles[:, i] = spin0 + sigma * hand * np.degrees(t) if n == self.spin else math.degrees(sol[n])
        from ..geometry.screw import screw_motion
        tips = screw_motion(np.broadcast_to(np.asarray(tip, float), (len(t), 3)), -t, v0, hand)
        xyz = self.control_points(tips, angles, tool_length)
        return np.c_[xyz, angles]

    def machine_joints(self, program_rows, tool_length=0.0):
        """Joint values (N, axes) of program rows: themselves without TCP; with TCP the linear joints that
        put the programmed tip (program coordinates) where the table carries it."""
        P = np.atleast_2d(np.asarray(program_rows, float))
        if not self.tcp:
            return P
        tips, _ = self.forward(P, tool_length)
        return np.c_[self.control_points(tips, P[:, 3:], tool_length, tcp=False), P[:, 3:]]

    def program_rows(self, joints, tool_length=0.0):
        """Program rows (N, axes) of joint rows: the inverse of :meth:`machine_joints`."""
        J = np.atleast_2d(np.asarray(joints, float))
        if not self.tcp:
            return J
        tips, _ = self.forward(J, tool_length, tcp=False)
        return np.c_[self.control_points(tips, J[:, 3:], tool_length, tcp=True), J[:, 3:]]

    def after_tool_change(self, joints):
        """Joint row (axes,) where the tool-change cycle leaves the machine that stood at ``joints`` (NaN where
        unknown): the ``tool_change_position`` axes set, the others where they were; all NaN (unknown) when the
        file gives no tool-change position."""
        if self.tool_change_position is None:
            return np.full(len(self.axis_names), np.nan)
        J = np.full(len(self.axis_names), np.nan) if joints is None else np.array(joints, float)
        for i, n in enumerate(self.axis_names):
            if n in self.tool_change_position:
                J[i] = self.tool_change_position[n]
        return J

    def tool_change_groups(self):
        """The axes (lists of indices into ``axis_names``) of the first move after a tool change, in the order
        they move, one block each.  It starts where the tool-change cycle leaves the machine, which the program
        cannot know.  Without TCP the rotary axes turn first, where the tool stands (they turn only the part or
        the head), then the linear axes move; with TCP it is one block, as turning a rotary axis would drag the
        linear axes along.  The posts write these blocks and :mod:`.toolpath` checks the same ones."""
        n = len(self.axis_names)
        if self.tcp or n <= 3:
            return [list(range(n))]
        return [list(range(3, n)), list(range(3))]

    def limit_violations(self, joints):
        """[(axis, value, min, max)] of joint rows (machine joints) outside the axis limits (worst per axis)."""
        J = np.atleast_2d(np.asarray(joints, float))
        bad = []
        for i, n in enumerate(self.axis_names):
            ax = self.axes[n]
            lo, hi = float(J[:, i].min()), float(J[:, i].max())
            if lo < ax.min - 1e-9:
                bad.append((n, lo, ax.min, ax.max))
            elif hi > ax.max + 1e-9:
                bad.append((n, hi, ax.min, ax.max))
        return bad


# ---------------------------------------------------------------------- loading
def _axis(name, d, kind):
    key = f"{kind}_axes.{name}"
    if not isinstance(d, dict):
        raise MachineError(f"{key} must be an object, got {d!r}")
    for k in ("min", "max", "max_feed", "rapid"):
        if k not in d:
            raise MachineError(f"missing key {key}.{k}")
    bound = MAX_LENGTH_MM if kind == "linear" else MAX_ANGLE_DEG
    ax = Axis(name, _num(d["min"], f"{key}.min", -bound, bound), _num(d["max"], f"{key}.max", -bound, bound),
              _num(d["max_feed"], f"{key}.max_feed", positive=True), _num(d["rapid"], f"{key}.rapid", positive=True))
    if not ax.min < ax.max:
        raise MachineError(f"{key}: min {ax.min:g} must be below max {ax.max:g}")
    if kind == "rotary":
        if d.get("on") not in ("table", "head"):
            raise MachineError(f"{key}.on must be 'table' or 'head', got {d.get('on')!r}")
        ax.on = d["on"]
        ax.direction = _vec(d.get("direction"), f"{key}.direction", unit=True)
        ax.pivot = _vec(d.get("pivot", [0.0, 0.0, 0.0]), f"{key}.pivot")
    return ax


def _tool_change_position(d, axes):
    """The optional ``tool_change_position``: joint values of X, Y, Z (required) and of any rotary axis the
    tool-change cycle turns, inside the axis limits; None when the file has none."""
    if d is None:
        return None
    key = "tool_change_position"
    if not isinstance(d, dict):
        raise MachineError(f"{key} must be an object of axis values, got {d!r}")
    unknown = sorted(set(d) - set(axes))
    if unknown:
        raise MachineError(f"{key}.{unknown[0]}: no such axis on this machine (axes {', '.join(axes)})")
    missing = [n for n in LINEAR if n not in d]
    if missing:
        raise MachineError(f"{key} must give {', '.join(missing)} (the linear axes; rotaries are optional)")
    return {n: _num(d[n], f"{key}.{n}", lo=axes[n].min, hi=axes[n].max) for n in axes if n in d}


# the least input increments a machine file may give (a control's IS-A .. IS-E): powers of ten
INCREMENTS = (0.1, 0.01, 0.001, 0.0001, 0.00001, 0.000001)


def _increment(v, key):
    """An optional least input increment (``controller.increment_mm`` / ``increment_deg``): one of INCREMENTS."""
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not any(abs(v - i) <= 1e-12 * i for i in INCREMENTS):
        raise MachineError(f"{key} must be the control's least input increment, one of "
                           f"{', '.join(f'{i:g}' for i in INCREMENTS)}, got {v!r}")
    return next(i for i in INCREMENTS if abs(v - i) <= 1e-12 * i)


def increment_decimals(increment):
    """Decimals of a least input increment of :data:`INCREMENTS` (0.001 -> 3)."""
    return INCREMENTS.index(increment) + 1


def _reference_position(d, axes, retract):
    """The optional ``reference_position``: the joint value of the retract axis (``retract``: its name and end of
    travel) that a reference return (Fanuc ``G28``) takes it to, inside its travel; None when the file has none."""
    if d is None:
        return None
    key = "reference_position"
    name = retract[0]
    if not isinstance(d, dict):
        raise MachineError(f"{key} must be an object such as {{\"{name}\": {retract[1]:g}}}, got {d!r}")
    other = sorted(set(d) - {name})
    if other:
        raise MachineError(f"{key}.{other[0]}: a reference return moves the retract axis {name} alone (the linear "
                           f"axis along tool_axis); give {name} only")
    if name not in d:
        raise MachineError(f"{key} must give {name}, the retract axis (the linear axis along tool_axis)")
    return {name: _num(d[name], f"{key}.{name}", lo=axes[name].min, hi=axes[name].max)}


def parse_machine(data, source="<dict>"):
    """A :class:`Machine` from a decoded flank-machine/1 document; :class:`MachineError` names the key."""
    if not isinstance(data, dict):
        raise MachineError(f"{source}: a machine file must be a JSON object")
    if data.get("schema") != SCHEMA:
        raise MachineError(f"schema must be {SCHEMA!r}, got {data.get('schema')!r}")
    for key in ("name", "linear_axes", "rotary_axes", "rotor_mount", "controller"):
        if key not in data:
            raise MachineError(f"missing key {key!r}")
    if not isinstance(data["name"], str) or not data["name"]:
        raise MachineError(f"name must be a non-empty string, got {data['name']!r}")
    if not data["name"].isascii() or not data["name"].isprintable():
        # the programs' comments carry it: a line break or a character outside ASCII would break them
        raise MachineError(f"name {data['name']!r} must be printable ASCII (no line breaks): the programs' "
                           "comments carry it")
    lin, rot = data["linear_axes"], data["rotary_axes"]
    if not isinstance(lin, dict) or sorted(lin) != list(LINEAR):
        raise MachineError(f"linear_axes must define exactly X, Y, Z, got {sorted(lin) if isinstance(lin, dict) else lin!r}")
    if not isinstance(rot, dict) or len(rot) != 2 or not set(rot) <= set(ROTARY):
        raise MachineError(f"rotary_axes must define two of A, B, C, got {sorted(rot) if isinstance(rot, dict) else rot!r}")
    axes = {n: _axis(n, lin[n], "linear") for n in LINEAR}
    axes.update({n: _axis(n, rot[n], "rotary") for n in ROTARY if n in rot})
    chains = {}
    for kind in ("table", "head"):
        key = f"{kind}_chain"
        chain = data.get(key, [n for n in ROTARY if n in rot and rot[n]["on"] == kind])
        want = sorted(n for n in rot if rot[n]["on"] == kind)
        if not isinstance(chain, list) or sorted(chain) != want:
            raise MachineError(f"{key} must list the {kind} rotary axes {want} (base first), got {chain!r}")
        chains[kind] = chain
    if not chains["table"]:
        raise MachineError("table_chain is empty: the rotor must turn on a table rotary axis")
    mount = data["rotor_mount"]
    if not isinstance(mount, dict) or "z" not in mount or "x" not in mount:
        raise MachineError(f"rotor_mount must give the machine directions of the rotor's 'z' and 'x', got {mount!r}")
    ez, ex = _direction(mount["z"], "rotor_mount.z"), _direction(mount["x"], "rotor_mount.x")
    if abs(ez @ ex) > 0:
        raise MachineError(f"rotor_mount.x {mount['x']!r} must be perpendicular to rotor_mount.z {mount['z']!r}")
    ctrl = data["controller"]
    if not isinstance(ctrl, dict) or not isinstance(ctrl.get("tcp"), bool):
        raise MachineError(f"controller.tcp must be true or false, got {ctrl.get('tcp') if isinstance(ctrl, dict) else ctrl!r}")
    spindle = data.get("spindle", {"max_rpm": 24000})
    version = data.get("version", 1)
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise MachineError(f"version must be an integer >= 1, got {version!r}")
    tla = data.get("tool_length_in_pivot", False)
    if not isinstance(tla, bool):
        raise MachineError(f"tool_length_in_pivot must be true or false, got {tla!r}")
    m = Machine(name=data["name"], description=str(data.get("description", "")), version=version,
                tcp=ctrl["tcp"], axes=axes, table_chain=chains["table"], head_chain=chains["head"],
                pivot_length=_num(data.get("pivot_length", 0.0), "pivot_length", lo=0.0, hi=MAX_LENGTH_MM),
                tool_length_in_pivot=tla, mount=np.c_[ex, np.cross(ez, ex), ez],
                tool_axis=_direction(data.get("tool_axis", "+Z"), "tool_axis"),
                max_rpm=_num(spindle.get("max_rpm") if isinstance(spindle, dict) else spindle, "spindle.max_rpm",
                             positive=True),
                tool_change_s=_num(data.get("tool_change_s", 0.0), "tool_change_s", lo=0.0), source=source,
                notes=list(data.get("notes", [])),
                tool_change_position=_tool_change_position(data.get("tool_change_position"), axes))
    m.reference_position = _reference_position(data.get("reference_position"), axes, m.retract_axis)
    m.increment_mm = _increment(ctrl.get("increment_mm"), "controller.increment_mm")
    m.increment_deg = _increment(ctrl.get("increment_deg"), "controller.increment_deg")
    spin = m.axes[m.spin]
    if abs(abs(float(spin.direction @ m.mount[:, 2])) - 1.0) > 1e-9 or np.linalg.norm(
            np.cross(spin.pivot, m.mount[:, 2])) > 1e-9 * (1.0 + np.linalg.norm(spin.pivot)):
        raise MachineError(f"rotary_axes.{m.spin} (the innermost table axis) must carry the rotor on its own axis: "
                           f"direction {spin.direction.tolist()} and pivot {spin.pivot.tolist()} must lie on the "
                           f"rotor axis {m.mount[:, 2].tolist()} through program zero")
    tilt = m.axes[m.tilt]
    if tilt.on == "table" and m.table_chain[0] != m.tilt:
        raise MachineError(f"table_chain {m.table_chain}: the spin axis {m.spin} must be the innermost (last)")
    return m


def load_machine(name_or_path):
    """A built-in machine by name or a machine file by path."""
    name = str(name_or_path)
    if os.path.isfile(name):
        path = name
    elif name in builtin_machines():
        path = os.path.join(MACHINE_DIR, name + ".json")
    elif os.path.isdir(name):
        raise MachineError(f"machine {name!r} is a folder: give a machine file (flank-machine/1 JSON) or one of "
                           f"{', '.join(builtin_machines())}")
    else:
        raise MachineError(f"unknown machine {name!r}: give a machine file or one of {', '.join(builtin_machines())}")
    try:
        with open(path, encoding="utf-8") as fh:
            data = json.load(fh)
    except json.JSONDecodeError as e:
        raise MachineError(f"{path}: not valid JSON ({e})") from None
    except UnicodeDecodeError:
        raise MachineError(f"{path}: not a text file (a machine file is JSON text)") from None
    try:
        return parse_machine(data, source=path)
    except MachineError as e:
        raise MachineError(f"{path}: {e}") from None
