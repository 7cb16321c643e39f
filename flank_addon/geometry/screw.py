"""Screw (helical) motion about the z-axis, Bizzarri, Bo & Bartoň Eq. (1).

A right-handed screw turns a point by +t about z and advances it by v0*t;
a left-handed screw turns by -t and advances by v0*t.  ``v0`` is the axial
advance per radian, so the pitch is 2*pi*v0.  Handedness is encoded as
``hand = +1`` (right) or ``-1`` (left) throughout the package.
"""
import numpy as np

HANDS = {"right": 1, "left": -1}
# v0 / outer radius below which a screw is a surface of revolution to the numbers (mesh analysis, built-ins)
MIN_PITCH_RATIO = 1e-3


def hand_sign(handedness):
    """'right'/'left' (or +1/-1) -> +1/-1."""
    if isinstance(handedness, str):
        try:
            return HANDS[handedness]
        except KeyError:
            raise ValueError(f"handedness must be 'right' or 'left', got {handedness!r}") from None
    h = int(handedness)
    if h not in (1, -1):
        raise ValueError(f"handedness sign must be +1 or -1, got {handedness!r}")
    return h


def hand_name(hand):
    return "right" if hand_sign(hand) > 0 else "left"


def rotate2d(xy, angle):
    """Rotate 2D points ``xy`` (..., 2) by ``angle`` (broadcastable to ...)."""
    c, s = np.cos(angle), np.sin(angle)
    x, y = xy[..., 0], xy[..., 1]
    return np.stack([c * x - s * y, s * x + c * y], axis=-1)


def screw_motion(points, t, v0, handedness="right"):
    """Apply S_t of Bizzarri, Bo & Bartoň Eq. (1) to 3D points (..., 3); ``t`` broadcasts."""
    h = hand_sign(handedness)
    p = np.asarray(points, dtype=float)
    t = np.asarray(t, dtype=float)
    angle = h * t
    return screwed(p[..., 0], p[..., 1], p[..., 2], t, np.cos(angle), np.sin(angle), v0)


def screw_velocity(points, v0, hand=1.0):
    """Velocity (..., 3) of the screw S_t of Eq. (1) at the points (..., 3), per unit t: (-h y, h x, v0) for the
    hand h = +1 (right) or -1 (left).  For a screw about another axis see
    :func:`.rotor_analysis.axis_screw_velocity`."""
    p = np.asarray(points, float)
    return np.stack([-hand * p[..., 1], hand * p[..., 0], np.full(p.shape[:-1], v0)], -1)


def screwed(x, y, z, t, c, s, v0):
    """:func:`screw_motion` of the points (x, y, z) (arrays or scalars that broadcast), given c and s, the cosine
    and sine of the turn h t: the rotation of rotate2d written straight into the result (the planners call this
    very often on a few points, where every numpy call counts; a caller that has c and s already passes them)."""
    rx, ry = c * x - s * y, s * x + c * y
    z = z + v0 * t
    out = np.empty(np.broadcast(rx, z).shape + (3,))
    out[..., 0], out[..., 1], out[..., 2] = rx, ry, z
    return out


def screw_to_plane(points, v0, handedness="right"):
    """Screw each 3D point along its own helix into the plane z = 0.

    Returns the 2D points (..., 2).  Distances to a helical surface are
    invariant under the screw, so this is how every 3D query is reduced to
    a planar one.
    """
    p = np.asarray(points, dtype=float)
    return screw_motion(p, -p[..., 2] / v0, v0, handedness)[..., :2]


def helix_points(xy, t, v0, handedness="right"):
    """Points S_t(x, y, 0) for planar points (N, 2) and parameters t (M,) -> (N, M, 3)."""
    xy = np.asarray(xy, dtype=float)
    t = np.asarray(t, dtype=float)
    p3 = np.concatenate([xy, np.zeros(xy.shape[:-1] + (1,))], axis=-1)
    return screw_motion(p3[:, None, :], t[None, :], v0, handedness)
