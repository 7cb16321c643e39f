"""Guiding curves on a free-form triangle-mesh surface (Rajain et al. 2023 §5, Figs. 5, 9, 10, Remarks 1 and 3).

Rajain et al. 2023 plans a family of M strips of a conical tool.  The strips meet along *guiding curves*
g_1 .. g_(M+1) on the surface Phi: the tool tip of strip i and the tool base of strip i - 1 both
follow g_i (Eq. (7) offsets them by r1 and r2 along the surface normal).  The guiding curves are
level sets of one scalar function G on Phi that is fair, has a gradient orthogonal to the
user's guiding direction (so the curves run *along* it) and of constant length (so that the
curves are evenly spaced); consecutive curves are d = sqrt(L^2 - (r2 - r1)^2) apart (§5, §7.2),
the width of a planar strip milled by a cone of axis length L touching the plane at both ends.

This module builds that part of the method on a mesh, with scipy.sparse throughout:

1. **Mesh operators** (:func:`gradient_matrix`, :func:`cotan_laplacian`, :func:`vertex_areas`,
   :func:`vertex_normals`): piecewise-linear hat functions; the gradient of a vertex function is
   constant per face; the cotangent Laplacian is the stiffness matrix grad^T diag(area) grad.
2. **Guiding field** X, a unit tangent field (Rajain et al. 2023 §3 input options):
   (i) given by the user as vectors per vertex or per face (:func:`field_from_vectors`: projected
   into the tangent planes, normalised); or (ii) one tangent vector at a central point,
   propagated over the surface (:func:`propagate_direction`).  The paper does not say how it
   spreads the single vector (it refers to [10] for the scalar function only).  We transport it
   in the Levi-Civita sense: one implicit step of the *vector heat method* (Sharp, Soliman, Crane
   2019), (M + t L_conn) z = M delta_c z_0, with the connection Laplacian L_conn whose edge
   transports are the minimal rotations between the two vertex normals, followed by
   normalisation.  Where the surface is developable (plane, cylinder, cone, any ruled developable
   such as the blade or the gear flank) a parallel field exists, the transport is path-independent
   and the result *is* that parallel field, exactly, whatever t (the heat kernel only scales it).
   On curved surfaces, no parallel field exists; the diffusion averages the transports over
   paths; a large t (default: the squared diameter of the mesh) gives the smoothest field.
   ``method='projection'`` instead projects the given 3D vector into every tangent plane
   (simpler, but depends on the embedding and fails where the surface turns towards the vector).
3. **Guiding function** G (:func:`guiding_function`), a sparse linear least-squares problem.
   With Y = n x X (the unit tangent orthogonal to X) and per-face gradients grad G:

       w_orth  sum_f A_f (grad G . X)^2           level sets along X (the paper's "perpendicular")
     + w_unit  sum_f A_f (grad G . Y - 1)^2       |grad G| = 1: G measures distance across X
     + w_fair  A_tot sum_(interior i) (L G)_i^2 / M_i   fairness (discrete Laplacian^2; zero
                                                   for linear functions, so it never biases a plane)

   with G = 0 at the central vertex.  For w_orth = w_unit (the default) the first two terms are
   sum_f A_f |grad G - Y|^2, i.e. the Poisson problem L G = div Y.  On a curved surface both
   wishes cannot hold at once (the field's integral curves spread and gather); raising w_orth
   makes the curves follow X more closely and their spacing vary more, lowering it the reverse.
   On the default bump (``freeform_surfaces.bump``): w_orth = 4 gives 0.19 deg rms deviation from
   X and spacing -3 % .. +7 %; w_orth = 1 gives 0.5 deg and -2.4 % .. +5.6 %; w_orth = 0.25 gives
   1.1 deg and -1.6 % .. +4 %.  (Re-linearising the unit term about the current gradient
   direction, an eikonal-style iteration, changed none of these figures, so it is not done.)
   Finally G is divided by its area-weighted mean gradient length, so that differences of G are
   surface distances across the curves (``scaling='min'``: by the smallest, so no spacing
   exceeds d).
4. **Level sets** (:func:`level_set`): marching triangles on the piecewise-linear G; every crossed
   edge gives one point, each crossed face one segment; the segments' connected components
   (scipy.sparse.csgraph) are ordered into polylines (open ones from an end, closed ones
   repeated at the end), oriented along X.  :func:`level_values` places the levels at spacing d
   through the central point's level G = 0.
5. **Base points** (:func:`base_points`, Fig. 10): points at arc-length step <= h along the first
   curve (h = 1/100 of the bounding-box diagonal, §5), both ends included; the base points of
   g_(i+1) are the intersections of g_(i+1) with the normal planes of g_i at its base points (the
   nearest intersection, if within ``max_gap``).  As Remark 1 requires, a normal plane may miss
   g_(i+1) (that ruling is dropped, the strip is shorter) and parts of g_(i+1) that no plane
   reaches get new base points at step <= h.  Each base point carries a *column* id; a strip i
   (Remark 3) pairs the base points of g_i and g_(i+1) with equal columns, so strips have their
   own lengths N_i.

Everything is plain numpy / scipy (sparse, sparse.linalg.splu, sparse.csgraph,
spatial.cKDTree).
"""
import math
from dataclasses import dataclass, field as dataclass_field
from typing import List

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, depth_first_order
from scipy.sparse.linalg import splu
from scipy.spatial import cKDTree

from ...geometry.triangles import areas_normals, corner_cross, corners_angles, face_areas_normals

MAX_FACES = 5_000_000
MIN_AREA_REL = 1e-14          # faces below this x (bounding-box diagonal)^2 are degenerate
MAX_TILT_DEG = 85.0           # a guiding vector may lean at most this far out of the tangent plane
MAX_LEVELS = 10_000
MAX_BASE_POINTS = 1_000_000


# ============================================================================ validation
def _finite_array(name, a, shape_tail):
    try:
        a = np.asarray(a, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a numeric array of shape (n, {shape_tail})") from None
    if a.ndim != 2 or a.shape[1] != shape_tail:
        raise ValueError(f"{name} must have shape (n, {shape_tail}), got {a.shape}")
    bad = ~np.isfinite(a).all(axis=1)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise ValueError(f"{name}[{k}] = {a[k].tolist()} is not finite ({int(bad.sum())} rows with NaN/inf)")
    return a


def validate_mesh(vertices, faces):
    """Checked copies (V (n, 3) float, F (m, 3) int64) of a triangle mesh, or ValueError.

    Rejected: non-finite coordinates; no faces; more than MAX_FACES faces; indices out of range;
    a face repeating a vertex; faces of area <= MIN_AREA_REL x (bounding-box diagonal)^2;
    unused vertices; edges of more than two faces; inconsistently oriented neighbours; a mesh in
    more than one connected piece.  Messages name the element, its value and the limit.
    """
    V = _finite_array("vertices", vertices, 3)
    try:
        F = np.asarray(faces)
    except (TypeError, ValueError):
        raise ValueError("faces must be an integer array of shape (m, 3)") from None
    if F.ndim != 2 or F.shape[1] != 3:
        raise ValueError(f"faces must have shape (m, 3), got {F.shape}")
    if len(F) == 0:
        raise ValueError("the mesh has no faces (at least 1 triangle needed)")
    if len(F) > MAX_FACES:
        raise ValueError(f"the mesh has {len(F)} faces, above the limit {MAX_FACES}")
    if not np.issubdtype(F.dtype, np.integer):
        if not (np.isfinite(F).all() and (F == np.round(F)).all()):
            raise ValueError("faces must hold integer vertex indices")
    F = F.astype(np.int64)
    lo, hi = int(F.min()), int(F.max())
    if lo < 0 or hi >= len(V):
        raise ValueError(f"face index {lo if lo < 0 else hi} is outside 0..{len(V) - 1} "
                         f"(the mesh has {len(V)} vertices)")
    rep = (F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 2] == F[:, 0])
    if rep.any():
        k = int(np.flatnonzero(rep)[0])
        raise ValueError(f"face {k} = {F[k].tolist()} repeats a vertex")
    used = np.zeros(len(V), bool)
    used[F.ravel()] = True
    if not used.all():
        k = int(np.flatnonzero(~used)[0])
        raise ValueError(f"vertex {k} is not used by any face ({int((~used).sum())} unused vertices); "
                         f"remove loose vertices")
    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    area, _ = face_areas_normals(V, F)
    limit = MIN_AREA_REL * diag * diag
    small = area <= limit
    if small.any():
        k = int(np.flatnonzero(small)[0])
        raise ValueError(f"face {k} has area {area[k]:.3g}, at or below the limit {limit:.3g} "
                         f"(1e-14 x bounding-box diagonal^2; {int(small.sum())} degenerate faces)")
    edges, face_edges, count, forward = _edge_table(F, len(V))
    if (count > 2).any():
        k = int(np.flatnonzero(count > 2)[0])
        raise ValueError(f"edge {edges[k].tolist()} is shared by {int(count[k])} faces "
                         f"(limit 2: the surface must be a manifold)")
    bad = (count == 2) & (forward != 1)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise ValueError(f"the two faces at edge {edges[k].tolist()} are oriented oppositely; "
                         f"orient all faces consistently")
    adj = sp.coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(len(V), len(V)))
    ncomp, _ = connected_components(adj, directed=False)
    if ncomp > 1:
        raise ValueError(f"the mesh has {ncomp} connected pieces (limit 1); plan each surface separately")
    return V, F


def _edge_table(F, n_vertices):
    """Undirected edges (E, 2) (sorted pairs), face_edges (F, 3) with face_edges[f, k] the edge
    (F[f, k], F[f, k+1]) i.e. opposite corner k + 2, the number of faces per edge (E,), and how
    many of its half-edges run from the lower to the higher index (E,)."""
    a = F.ravel()
    b = np.roll(F, -1, axis=1).ravel()
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = lo * n_vertices + hi
    uniq, inv, count = np.unique(key, return_inverse=True, return_counts=True)
    edges = np.c_[uniq // n_vertices, uniq % n_vertices]
    forward = np.bincount(inv, weights=(a < b).astype(float), minlength=len(uniq))
    return edges, inv.reshape(-1, 3), count, forward


def mesh_edges(faces, n_vertices):
    """Undirected edges (E, 2), face_edges (F, 3) (edge of corners k, k+1 of each face) and the
    boundary flag per edge (E,) of a validated mesh."""
    edges, face_edges, count, _ = _edge_table(np.asarray(faces, np.int64), int(n_vertices))
    return edges, face_edges, count == 1


def _check_direction(name, d):
    try:
        d = np.asarray(d, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be three numbers") from None
    if d.shape != (3,):
        raise ValueError(f"{name} must be a 3-vector, got shape {d.shape}")
    if not np.isfinite(d).all():
        raise ValueError(f"{name} = {d.tolist()} is not finite")
    n = float(np.linalg.norm(d))
    if not n > 0:
        raise ValueError(f"{name} = {d.tolist()} has length 0 (a guiding direction needs length > 0)")
    return d / n


def default_spacing(r1, r2, L):
    """Distance d = sqrt(L^2 - (r2 - r1)^2) between neighbouring guiding curves (Rajain et al. 2023 §5, §7.2):
    the width of the strip a cone with axis length L and end radii r1, r2 mills on a plane it
    touches at both ends."""
    vals = {}
    for name, v in (("r1", r1), ("r2", r2), ("L", L)):
        try:
            v = float(v)
        except (TypeError, ValueError):
            raise ValueError(f"{name} = {v!r} is not a number") from None
        if not math.isfinite(v):
            raise ValueError(f"{name} = {v!r} is not finite")
        vals[name] = v
    if vals["r1"] < 0 or vals["r2"] < 0:
        raise ValueError(f"tool radii must be >= 0, got r1 = {vals['r1']}, r2 = {vals['r2']}")
    dr = vals["r2"] - vals["r1"]
    if not vals["L"] > abs(dr):
        raise ValueError(f"axis length L = {vals['L']} must exceed |r2 - r1| = {abs(dr)} (else the cone cannot "
                         f"touch a plane at both ends)")
    return math.sqrt(vals["L"] ** 2 - dr * dr)


def _solve_symmetric(A, b):
    """Solve A x = b for a sparse symmetric (or Hermitian) positive definite A: SuperLU
    (scipy.sparse.linalg.splu) in symmetric mode, minimum-degree ordering of A^T + A, diagonal
    pivots (no pivoting is needed for a positive definite A).  On the 20k-triangle test meshes
    this takes 0.13 s for the guiding function, against 0.20 s with spsolve's default (COLAMD,
    partial pivoting) and 2.3 s with the same ordering and partial pivoting."""
    lu = splu(sp.csc_matrix(A), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
              options={"SymmetricMode": True})
    return lu.solve(b)


# ============================================================================ mesh operators
def hat_gradients(vertices, faces):
    """Gradients (F, 3, 3) of the hat functions: [f, k] is the gradient on face f of the linear
    function that is 1 at corner k and 0 at the other two, n_f x e_k / (2 A_f), e_k the edge
    opposite corner k (counter-clockwise)."""
    V = np.asarray(vertices, float)
    F = np.asarray(faces)
    x = V[F]                                              # (F, 3, 3)
    e = np.roll(x, -2, axis=1) - np.roll(x, -1, axis=1)   # e_k = x_(k+2) - x_(k+1)
    area, n = face_areas_normals(V, F)
    return np.cross(n[:, None, :], e) / (2 * area)[:, None, None]


def gradient_matrix(vertices, faces):
    """Sparse (3F, V) matrix D with (D g)[3 f + c] the c-th component of the gradient of the
    piecewise-linear vertex function g on face f (exact for functions linear on the face)."""
    F = np.asarray(faces)
    H = hat_gradients(vertices, faces)                    # (F, corner, comp)
    rows = (3 * np.arange(len(F))[:, None, None] + np.arange(3)[None, None, :]).repeat(3, axis=1)
    cols = np.broadcast_to(F[:, :, None], H.shape)
    return sp.csr_matrix((H.ravel(), (rows.ravel(), cols.ravel())), shape=(3 * len(F), len(vertices)))


def directional_derivative_matrix(vertices, faces, face_vectors):
    """Sparse (F, V) matrix: row f gives grad g . w_f on face f for a vertex function g
    (face_vectors w (F, 3))."""
    F = np.asarray(faces)
    H = hat_gradients(vertices, faces)
    data = np.einsum("fkc,fc->fk", H, np.asarray(face_vectors, float))
    rows = np.repeat(np.arange(len(F)), 3)
    return sp.csr_matrix((data.ravel(), (rows, F.ravel())), shape=(len(F), len(vertices)))


def cotan_weights(vertices, faces):
    """Per-face cotangent halves (F, 3): [f, k] = cot(angle at corner k) / 2, the weight that face f
    gives to the edge opposite corner k, i.e. (F[f, k+1], F[f, k+2])."""
    V = np.asarray(vertices, float)
    F = np.asarray(faces)
    x = V[F]
    u = np.roll(x, -1, axis=1) - x                        # corner k -> k+1
    w = np.roll(x, -2, axis=1) - x                        # corner k -> k+2
    dot = (u * w).sum(-1)
    cr = np.linalg.norm(np.cross(u, w), axis=-1)
    return 0.5 * dot / cr


def cotan_laplacian(vertices, faces):
    """Cotangent Laplacian (V, V), symmetric positive semidefinite: (L g)_i = sum_j w_ij (g_i - g_j)
    with w_ij = (cot alpha_ij + cot beta_ij) / 2.  Equals gradient_matrix^T diag(A) gradient_matrix
    (A the face areas repeated per component), and L g = 0 at interior vertices of a flat mesh for
    every linear g (linear precision)."""
    F = np.asarray(faces)
    n = len(vertices)
    c = cotan_weights(vertices, faces)
    i = np.roll(F, -1, axis=1).ravel()
    j = np.roll(F, -2, axis=1).ravel()
    w = c.ravel()
    W = sp.coo_matrix((np.r_[w, w], (np.r_[i, j], np.r_[j, i])), shape=(n, n)).tocsr()
    return (sp.diags(np.asarray(W.sum(axis=1)).ravel()) - W).tocsr()


def vertex_areas(vertices, faces):
    """Barycentric vertex areas (V,): one third of the area of every incident face (sum = total)."""
    area, _ = face_areas_normals(vertices, faces)
    return np.bincount(np.asarray(faces).ravel(), weights=np.repeat(area / 3, 3), minlength=len(vertices))


def vertex_normals(vertices, faces):
    """Unit vertex normals (V, 3): face normals weighted by the corner angles (Thürmer-Wüthrich)."""
    F = np.asarray(faces).astype(np.intp, copy=False)
    corners = np.asarray(vertices, float).take(F, axis=0)      # (F, 3, 3), gathered once for both
    _, n = areas_normals(corner_cross(corners[:, 0], corners[:, 1], corners[:, 2]))
    ang = corners_angles(corners)
    acc = np.zeros((len(vertices), 3))
    np.add.at(acc, F.ravel(), (ang[..., None] * n[:, None, :]).reshape(-1, 3))
    return acc / np.linalg.norm(acc, axis=1, keepdims=True)


def boundary_vertices(faces, n_vertices):
    """Boolean (V,): vertices on a boundary edge (an edge of only one face)."""
    edges, _, bnd = mesh_edges(faces, n_vertices)
    out = np.zeros(int(n_vertices), bool)
    out[edges[bnd].ravel()] = True
    return out


# ============================================================================ guiding field
@dataclass
class GuidingField:
    """Unit tangent guiding field: per vertex (V, 3) and per face (F, 3) (in the face plane);
    ``source`` the central vertex (or -1 for a user field), ``method`` how it was made."""
    vertex: np.ndarray
    face: np.ndarray
    source: int
    method: str


def tangent_basis(normals):
    """Orthonormal tangent frames (e1, e2), each (n, 3), with e2 = n x e1, for unit normals (n, 3)."""
    n = np.asarray(normals, float)
    a = np.zeros_like(n)
    a[np.arange(len(n)), np.argmin(np.abs(n), axis=1)] = 1.0
    e1 = a - (a * n).sum(1, keepdims=True) * n
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, np.cross(n, e1)


def minimal_rotation(a, b, v):
    """Apply to v (n, 3) the rotation about a x b that takes unit a (n, 3) to unit b (n, 3):
    R v = (a.b) v + (a x b) x v + ((a x b).v) (a x b) / (1 + a.b).  Needs a.b > -1."""
    c = (a * b).sum(1, keepdims=True)
    k = np.cross(a, b)
    return c * v + np.cross(k, v) + (k * v).sum(1, keepdims=True) * k / (1 + c)


def connection_laplacian(vertices, faces, normals=None):
    """Connection Laplacian (V, V) complex Hermitian PSD on tangent vectors, with the tangent frames.

    A tangent vector at vertex i is the complex number z = a + i b for a e1_i + b e2_i.  Transport
    from j to i along edge ij is the minimal rotation taking n_j to n_i (a discrete Levi-Civita
    connection), in frame coordinates the factor r_ij = exp(i alpha_ij), r_ji = conj(r_ij).
    (L z)_i = sum_j w_ij (z_i - r_ij z_j), w_ij the cotangent weights clipped at 0 (so L stays
    PSD and the heat step below keeps positive kernels).  On a developable mesh with flat
    vertex stars, the parallel field is in the kernel: L z = 0.
    Returns (L (V, V) complex csr, e1 (V, 3), e2 (V, 3)).
    """
    V = np.asarray(vertices, float)
    F = np.asarray(faces, np.int64)
    N = vertex_normals(V, F) if normals is None else np.asarray(normals, float)
    e1, e2 = tangent_basis(N)
    n = len(V)
    c = cotan_weights(V, F)
    i = np.roll(F, -1, axis=1).ravel()
    j = np.roll(F, -2, axis=1).ravel()
    lo, hi = np.minimum(i, j), np.maximum(i, j)
    W = sp.coo_matrix((c.ravel(), (lo, hi)), shape=(n, n)).tocsr()   # sums the two faces of an edge
    W.sum_duplicates()
    Wc = W.tocoo()
    a, b, w = Wc.row, Wc.col, np.maximum(Wc.data, 0.0)
    if ((N[a] * N[b]).sum(1) <= -1 + 1e-9).any():
        k = int(np.flatnonzero((N[a] * N[b]).sum(1) <= -1 + 1e-9)[0])
        raise ValueError(f"the vertex normals at edge {[int(a[k]), int(b[k])]} are opposite; the mesh folds over")
    # transport b -> a: rotate e1_b by the minimal rotation n_b -> n_a, read it in a's frame
    v = minimal_rotation(N[b], N[a], e1[b])
    r = np.exp(1j * np.arctan2((v * e2[a]).sum(1), (v * e1[a]).sum(1)))
    off = sp.coo_matrix((np.r_[-w * r, -w * np.conj(r)], (np.r_[a, b], np.r_[b, a])), shape=(n, n))
    deg = np.bincount(np.r_[a, b], weights=np.r_[w, w], minlength=n)
    return (sp.diags(deg.astype(complex)) + off).tocsr(), e1, e2


def _face_field_from_vertex(vertices, faces, vertex_field):
    """Unit face field (F, 3): the mean of the corners' vectors projected into the face plane."""
    _, n = face_areas_normals(vertices, faces)
    m = np.asarray(vertex_field)[np.asarray(faces)].mean(axis=1)
    m -= (m * n).sum(1, keepdims=True) * n
    ln = np.linalg.norm(m, axis=1)
    if (ln <= 1e-9).any():
        k = int(np.flatnonzero(ln <= 1e-9)[0])
        raise ValueError(f"the guiding field cancels on face {k} (its corners' vectors oppose each other); "
                         f"the field has a singularity there")
    return m / ln[:, None]


def central_vertex(vertices, faces, point=None):
    """Index of the vertex nearest ``point`` (3,), or, if None, nearest the area-weighted centroid of
    the faces.  A point farther from the mesh than 10 % of its bounding-box diagonal is rejected."""
    V = np.asarray(vertices, float)
    tree = cKDTree(V)
    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    if point is None:
        area, _ = face_areas_normals(V, faces)
        c = (V[np.asarray(faces)].mean(1) * area[:, None]).sum(0) / area.sum()
        return int(tree.query(c)[1])
    p = np.asarray(point, dtype=float)
    if p.shape != (3,) or not np.isfinite(p).all():
        raise ValueError(f"point must be three finite numbers, got {np.asarray(point).tolist()}")
    dist, k = tree.query(p)
    if dist > 0.1 * diag:
        raise ValueError(f"point {p.tolist()} is {dist:.6g} from the nearest mesh vertex, above the limit "
                         f"{0.1 * diag:.6g} (10 % of the bounding-box diagonal)")
    return int(k)


def _tilt_check(name, vectors, normals, where, labels=None):
    """Projected unit tangents of vectors (n, 3) w.r.t. unit normals (n, 3); ValueError if a vector
    leans more than MAX_TILT_DEG out of the tangent plane (naming ``where`` and the row's label)."""
    t = vectors - (vectors * normals).sum(1, keepdims=True) * normals
    lt = np.linalg.norm(t, axis=1)
    tilt = np.degrees(np.arctan2(np.abs((vectors * normals).sum(1)), lt))
    bad = tilt > MAX_TILT_DEG
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        label = k if labels is None else labels[k]
        raise ValueError(f"{name} at {where} {label} makes {tilt[k]:.2f} deg with the tangent plane (limit "
                         f"{MAX_TILT_DEG:g} deg): it is (nearly) normal to the surface, so it gives no direction")
    return t / np.where(lt > 0, lt, 1.0)[:, None]


def propagate_direction(vertices, faces, direction, point=None, method="transport", diffusion_time=None):
    """Guiding field from a single tangent vector at a central point (Rajain et al. 2023 §3 option (ii), Fig. 5).

    direction (3,) is projected into the tangent plane of the central vertex (the vertex nearest
    ``point``, default the area centroid's nearest vertex).  method:

    'transport'   vector heat method: z = (M + t L_conn)^(-1) M delta z_0, normalised, with the
                  connection Laplacian of :func:`connection_laplacian` and barycentric mass M;
                  t = diffusion_time, default diameter^2 (bounding-box diagonal squared).  Exact
                  parallel transport wherever a parallel field exists (developable meshes).
    'projection'  the constant 3D vector projected into each vertex's tangent plane.

    Returns a :class:`GuidingField`.
    """
    V, F = validate_mesh(vertices, faces)
    return _propagate(V, F, direction, point, method, diffusion_time, vertex_normals(V, F))


def _propagate(V, F, direction, point, method, diffusion_time, N):
    """:func:`propagate_direction` on a mesh that :func:`validate_mesh` accepted, with its vertex normals N."""
    d = _check_direction("direction", direction)
    src = central_vertex(V, F, point)
    t0 = _tilt_check("direction", d[None], N[src:src + 1], "central vertex", [src])[0]
    if method == "projection":
        X = _tilt_check("the projected direction", np.broadcast_to(d, V.shape).copy(), N, "vertex")
    elif method == "transport":
        diag = float(np.linalg.norm(V.max(0) - V.min(0)))
        t = diag ** 2 if diffusion_time is None else float(diffusion_time)
        if not (math.isfinite(t) and t > 0):
            raise ValueError(f"diffusion_time = {diffusion_time!r} must be a finite number > 0")
        L, e1, e2 = connection_laplacian(V, F, N)
        M = vertex_areas(V, F)
        rhs = np.zeros(len(V), complex)
        rhs[src] = M[src] * complex(t0 @ e1[src], t0 @ e2[src])
        z = _solve_symmetric(sp.diags(M.astype(complex)) + t * L, rhs)
        mag = np.abs(z)
        small = mag <= 1e-12 * mag.max()
        if small.any() or not np.isfinite(z).all():
            k = int(np.flatnonzero(small | ~np.isfinite(z))[0])
            raise ValueError(f"the transported field vanishes at vertex {k} (|z| = {mag[k]:.3g}, limit "
                             f"{1e-12 * mag.max():.3g}); give a tangent field instead")
        z = z / mag
        X = z.real[:, None] * e1 + z.imag[:, None] * e2
    else:
        raise ValueError(f"method must be 'transport' or 'projection', got {method!r}")
    return GuidingField(X, _face_field_from_vertex(V, F, X), src, method)


def field_from_vectors(vertices, faces, vectors, location="auto"):
    """Guiding field from user vectors (Rajain et al. 2023 §3 option (i)): vectors (V, 3) per vertex or (F, 3) per
    face (``location`` 'vertex' / 'face', or 'auto' by the row count).  Each vector is projected
    into its tangent plane and normalised; per-face input gets vertex vectors as the
    area-weighted mean of the incident faces'."""
    V, F = validate_mesh(vertices, faces)
    W = _finite_array("field", vectors, 3)
    if location == "auto":
        if len(V) == len(F) and len(W) == len(V):
            raise ValueError("the mesh has as many vertices as faces; say location='vertex' or 'face'")
        location = "vertex" if len(W) == len(V) else "face" if len(W) == len(F) else None
        if location is None:
            raise ValueError(f"field has {len(W)} rows; need {len(V)} (per vertex) or {len(F)} (per face)")
    zero = np.linalg.norm(W, axis=1) == 0
    if zero.any():
        raise ValueError(f"field[{int(np.flatnonzero(zero)[0])}] is the zero vector (a direction needs length > 0)")
    area, fn = face_areas_normals(V, F)
    N = vertex_normals(V, F)
    if location == "vertex":
        if len(W) != len(V):
            raise ValueError(f"field has {len(W)} rows, the mesh {len(V)} vertices")
        X = _tilt_check("field", W, N, "vertex")
        return GuidingField(X, _face_field_from_vertex(V, F, X), -1, "field")
    if location != "face" or len(W) != len(F):
        raise ValueError(f"field has {len(W)} rows; location={location!r} needs {len(F)} (faces) "
                         f"or {len(V)} (vertices)")
    Xf = _tilt_check("field", W, fn, "face")
    acc = np.zeros((len(V), 3))
    np.add.at(acc, F.ravel(), np.repeat(Xf * area[:, None], 3, axis=0))
    X = _tilt_check("the averaged field", acc, N, "vertex")
    return GuidingField(X, Xf, -1, "field")


# ============================================================================ guiding function
@dataclass
class GuidingFunction:
    """G per vertex (V,) (0 at ``source``), its gradient per face (F, 3), the factor G was divided
    by (mean |grad G| before normalisation), and quality figures (area-weighted):
    ``angle_rms`` / ``angle_max`` the angle in degrees between the level-set direction and the
    field, ``grad_min`` / ``grad_max`` the range of |grad G|."""
    values: np.ndarray
    gradient: np.ndarray
    source: int
    scale: float
    angle_rms: float
    angle_max: float
    grad_min: float
    grad_max: float


def guiding_function(vertices, faces, face_field, source, w_orth=1.0, w_unit=1.0, w_fair=1e-3, scaling="mean"):
    """The fair scalar function G whose level sets follow the guiding field (Rajain et al. 2023 §5, after [10]).

    Minimises, over piecewise-linear G with G[source] = 0 (see the module docstring),
      w_orth sum A_f (grad G . X_f)^2 + w_unit sum A_f (grad G . Y_f - 1)^2
      + w_fair A_tot sum_(interior i) (L G)_i^2 / M_i,            Y_f = n_f x X_f,
    a sparse linear least-squares problem solved by its normal equations (SuperLU).  Linear
    functions are reproduced exactly where they fit (planes; parallel fields on developable
    meshes).  The default w_orth = w_unit is the Poisson problem L G = div Y.

    scaling: 'mean' divides G by its area-weighted mean |grad G| (level spacing d on average);
    'min' by its smallest |grad G| over the faces, so that no two neighbouring level sets are more
    than d apart anywhere (more curves, never a gap wider than the tool's strip); None keeps G.
    face_field (F, 3) unit tangents; returns a :class:`GuidingFunction`.
    """
    V = np.asarray(vertices, float)
    F = np.asarray(faces, np.int64)
    if scaling not in ("mean", "min", None):
        raise ValueError(f"scaling must be 'mean', 'min' or None, got {scaling!r}")
    for name, w in (("w_orth", w_orth), ("w_unit", w_unit), ("w_fair", w_fair)):
        if not (math.isfinite(w) and w >= 0):
            raise ValueError(f"{name} = {w!r} must be a finite number >= 0")
    if not w_unit > 0:
        raise ValueError("w_unit must be > 0 (without it G = 0 is optimal)")
    X = np.asarray(face_field, float)
    area, n = face_areas_normals(V, F)
    Y = np.cross(n, X)
    DX = directional_derivative_matrix(V, F, X)
    DY = directional_derivative_matrix(V, F, Y)
    Af = sp.diags(area)
    K = w_orth * (DX.T @ Af @ DX) + w_unit * (DY.T @ Af @ DY)
    if w_fair > 0:
        L = cotan_laplacian(V, F)
        inner = ~boundary_vertices(F, len(V))
        Li = L[inner]
        K = K + (w_fair * area.sum()) * (Li.T @ sp.diags(1.0 / vertex_areas(V, F)[inner]) @ Li)
    b = w_unit * (DY.T @ area)
    free = np.ones(len(V), bool)
    free[source] = False
    K = K.tocsr()
    G = np.zeros(len(V))
    G[free] = _solve_symmetric(K[free][:, free], b[free])
    if not np.isfinite(G).all():
        raise ValueError("the guiding-function system is singular (is the mesh connected and the field valid?)")
    grad = (gradient_matrix(V, F) @ G).reshape(-1, 3)
    gn = np.linalg.norm(grad, axis=1)
    scale = float((gn * area).sum() / area.sum()) if scaling != "min" else float(gn.min())
    if not scale > 0:
        raise ValueError(f"the guiding function has |grad G| = {scale:.3g} (limit > 0): the field gives no direction")
    if scaling is None:
        scale = 1.0
    G, grad, gn = G / scale, grad / scale, gn / scale
    ang = np.degrees(np.arctan2(np.abs((grad * X).sum(1)), (grad * Y).sum(1)))
    return GuidingFunction(G, grad, int(source), scale,
                           float(np.sqrt((ang ** 2 * area).sum() / area.sum())), float(ang.max()),
                           float(gn.min()), float(gn.max()))


# ============================================================================ level sets
@dataclass
class Polyline:
    """A level-set polyline: points (n, 3), unit surface normals there (n, 3) (interpolated vertex
    normals), the face of each segment (n - 1,), the mesh edge (n, 2) and its parameter t (n,) of
    each point (point = (1 - t) V[a] + t V[b]), ``closed`` (then points[-1] == points[0])."""
    points: np.ndarray
    normals: np.ndarray
    faces: np.ndarray
    edges: np.ndarray
    t: np.ndarray
    closed: bool
    level: float

    @property
    def arclength(self):
        """Cumulative arc length at the points (n,), starting at 0."""
        return np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(self.points, axis=0), axis=1))]

    @property
    def length(self):
        return float(self.arclength[-1])

    def at(self, s):
        """Points (k, 3), unit normals (k, 3) and segment indices (k,) at arc lengths s (k,),
        clamped to [0, length]."""
        cum = self.arclength
        s = np.clip(np.asarray(s, float), 0.0, cum[-1])
        seg = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(cum) - 2)
        ln = cum[seg + 1] - cum[seg]
        u = np.where(ln > 0, (s - cum[seg]) / np.where(ln > 0, ln, 1.0), 0.0)[:, None]
        p = (1 - u) * self.points[seg] + u * self.points[seg + 1]
        nr = (1 - u) * self.normals[seg] + u * self.normals[seg + 1]
        return p, nr / np.linalg.norm(nr, axis=1, keepdims=True), seg

    def tangent(self, s, half_window):
        """Unit tangents (k, 3) at arc lengths s (k,): chord from s - half_window to s + half_window
        (clamped at the ends), which smooths the polyline's facet-scale zigzag."""
        a, _, _ = self.at(np.asarray(s) - half_window)
        b, _, _ = self.at(np.asarray(s) + half_window)
        d = b - a
        return d / np.linalg.norm(d, axis=1, keepdims=True)


def level_set(vertices, faces, values, level, vertex_normals_=None, face_field=None, edge_table=None):
    """Polylines of {G = level} on the piecewise-linear vertex function ``values`` (V,).

    Marching triangles: a vertex counts as 'above' when G >= level; every edge with one end above
    and one below holds one crossing point, linearly interpolated; every face with a crossing
    holds one segment between its two crossed edges.  On a manifold mesh every crossed edge meets
    at most two segments, so the connected components of the segment graph are chains (open, from
    boundary to boundary) or cycles; each is ordered by a depth-first walk from one of its ends.
    Zero-length segments (a level through a vertex) are dropped.  Polylines are oriented so that
    they run along ``face_field`` (F, 3) when given.  Returns a list of :class:`Polyline`, longest
    first.
    """
    V = np.asarray(vertices, float)
    F = np.asarray(faces, np.int64)
    G = np.asarray(values, float)
    if edge_table is None:
        edges, face_edges, _ = mesh_edges(F, len(V))
    else:
        edges, face_edges = edge_table
    N = vertex_normals(V, F) if vertex_normals_ is None else vertex_normals_
    above = G >= level
    crossed = above[edges[:, 0]] != above[edges[:, 1]]
    nodes = np.flatnonzero(crossed)
    if len(nodes) == 0:
        return []
    remap = np.full(len(edges), -1)
    remap[nodes] = np.arange(len(nodes))
    nab = above[F].sum(1)
    cf = np.flatnonzero((nab == 1) | (nab == 2))
    fe = face_edges[cf]
    seg = remap[fe[crossed[fe]].reshape(-1, 2)]
    k = len(nodes)
    adj = sp.coo_matrix((np.r_[cf, cf] + 1.0, (np.r_[seg[:, 0], seg[:, 1]], np.r_[seg[:, 1], seg[:, 0]])),
                        shape=(k, k)).tocsr()
    deg = np.diff(adj.indptr)
    a, b = edges[nodes, 0], edges[nodes, 1]
    t = (level - G[a]) / (G[b] - G[a])
    pts = V[a] + t[:, None] * (V[b] - V[a])
    nrm = (1 - t)[:, None] * N[a] + t[:, None] * N[b]
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    ncomp, labels = connected_components(adj, directed=False)
    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    out = []
    for c in range(ncomp):
        members = np.flatnonzero(labels == c)
        ends = members[deg[members] == 1]
        closed = len(ends) == 0
        start = int(ends.min()) if len(ends) else int(members.min())
        order = depth_first_order(adj, start, directed=False, return_predecessors=False)
        if closed:
            order = np.r_[order, order[0]]
        if len(order) < 2:
            continue
        seg_faces = np.asarray(adj[order[:-1], order[1:]]).ravel().astype(np.int64) - 1
        p = pts[order]
        keep = np.r_[True, np.linalg.norm(np.diff(p, axis=0), axis=1) > 1e-13 * diag]
        if closed and not keep[-1] and len(keep) > 2:
            keep[-1], keep[-2] = True, False
        seg_keep = keep[1:]
        pl = Polyline(p[keep], nrm[order][keep], seg_faces[seg_keep], np.c_[a, b][order][keep], t[order][keep],
                      closed, float(level))
        if len(pl.points) < 2:
            continue
        if face_field is not None:
            d = np.diff(pl.points, axis=0)
            if (d * np.asarray(face_field)[pl.faces]).sum() < 0:
                pl = Polyline(pl.points[::-1].copy(), pl.normals[::-1].copy(), pl.faces[::-1].copy(),
                              pl.edges[::-1].copy(), pl.t[::-1].copy(), closed, pl.level)
        out.append(pl)
    out.sort(key=lambda q: -q.length)
    return out


def level_values(values, spacing, anchor=0.0):
    """Levels anchor + k spacing (all integers k) strictly inside (min G, max G), ascending.
    The extreme levels are kept at least 1 % of the spacing (and 1e-9 of the range) inside: a level
    closer to an extreme of G touches the border only along a sliver (e.g. a border row that the
    direction crosses at a tiny angle), whose strip would be a wedge of the surface's edge."""
    G = np.asarray(values, float)
    spacing = float(spacing)
    if not (math.isfinite(spacing) and spacing > 0):
        raise ValueError(f"spacing = {spacing!r} must be a finite number > 0")
    lo, hi = float(G.min()), float(G.max())
    pad = max(1e-9 * (hi - lo), 0.01 * spacing)
    k0 = math.ceil((lo + pad - anchor) / spacing)
    k1 = math.floor((hi - pad - anchor) / spacing)
    if k1 - k0 + 1 > MAX_LEVELS:
        raise ValueError(f"spacing {spacing:.6g} gives {k1 - k0 + 1} guiding curves over the range {hi - lo:.6g} "
                         f"of G, above the limit {MAX_LEVELS}")
    return anchor + spacing * np.arange(k0, k1 + 1)


def polyline_distance(points, polyline, return_arclength=False, chunk=1024):
    """Euclidean distance (k,) from points (k, 3) to the nearest point of ``polyline`` (a
    :class:`Polyline` or an (n, 3) array), exact over its segments (brute force in chunks); with
    ``return_arclength`` also the arc length (k,) of those nearest points on the polyline."""
    Q = polyline.points if isinstance(polyline, Polyline) else np.asarray(polyline, float)
    P = np.atleast_2d(np.asarray(points, float))
    a, d = Q[:-1], np.diff(Q, axis=0)
    seg_len = np.linalg.norm(d, axis=1)
    cum = np.r_[0.0, np.cumsum(seg_len)]
    dd = np.maximum(seg_len ** 2, 1e-300)
    out, arc = np.empty(len(P)), np.empty(len(P))
    for i in range(0, len(P), chunk):
        p = P[i:i + chunk, None, :]
        u = np.clip(((p - a) * d).sum(-1) / dd, 0.0, 1.0)
        d2 = (((a + u[..., None] * d) - p) ** 2).sum(-1)
        k = np.argmin(d2, axis=1)
        r = np.arange(len(k))
        out[i:i + chunk] = np.sqrt(d2[r, k])
        arc[i:i + chunk] = cum[k] + u[r, k] * seg_len[k]
    return (out, arc) if return_arclength else out


# ============================================================================ base points
@dataclass
class GuidingCurve:
    """One guiding curve g_i: its level of G and its polylines (one, or several pieces where the
    level set of G falls apart on this surface)."""
    level: float
    polylines: List[Polyline]


@dataclass
class BaseCurve:
    """Base points of one guiding curve (Rajain et al. 2023 Fig. 10), in order along each piece: points (N, 3),
    unit surface normals (N, 3) (the n_(i,j) of Eq. (7)), unit curve tangents (N, 3), column ids
    (N,), piece index (N,) into the curve's polylines, arc length on that piece (N,), and
    ``added`` (N,) True where the point was not a normal-plane intersection (Remark 1)."""
    level: float
    points: np.ndarray
    normals: np.ndarray
    tangents: np.ndarray
    columns: np.ndarray
    piece: np.ndarray
    arclength: np.ndarray
    added: np.ndarray


@dataclass
class Strip:
    """Strip i between guiding curves i and i + 1 (Remark 3: each strip has its own length N_i):
    the shared columns (N_i,), ordered along curve i, and the indices of those base points in
    BaseCurve i (``lower``) and i + 1 (``upper``)."""
    index: int
    columns: np.ndarray
    lower: np.ndarray
    upper: np.ndarray


def _even_params(s0, s1, step, include_start=True):
    """Arc lengths from s0 to s1 (inclusive) at the largest spacing <= step."""
    n = max(1, math.ceil((s1 - s0) / step - 1e-9))
    s = np.linspace(s0, s1, n + 1)
    return s if include_start else s[1:]


def _make_base_curve(curve, pieces, step):
    """BaseCurve from per-piece lists of (arclength (k,), columns (k,), added (k,))."""
    P, Nn, T, C, Pc, S, A = [], [], [], [], [], [], []
    for pi, (s, cols, add) in enumerate(pieces):
        if len(s) == 0:
            continue
        o = np.argsort(s, kind="stable")
        s, cols, add = s[o], cols[o], add[o]
        pl = curve.polylines[pi]
        p, nr, _ = pl.at(s)
        P.append(p), Nn.append(nr), T.append(pl.tangent(s, step / 2)), C.append(cols)
        Pc.append(np.full(len(s), pi)), S.append(s), A.append(add)
    if not P:
        z3 = np.zeros((0, 3))
        return BaseCurve(curve.level, z3, z3, z3, np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0),
                         np.zeros(0, bool))
    return BaseCurve(curve.level, *(np.concatenate(x) for x in (P, Nn, T, C, Pc, S, A)))


def _seed_curve(curve, step, next_col):
    """Base points on every piece of a curve at arc step <= step, both ends included."""
    pieces = []
    for pl in curve.polylines:
        s = _even_params(0.0, pl.length, step)
        pieces.append((s, np.arange(next_col, next_col + len(s)), np.zeros(len(s), bool)))
        next_col += len(s)
    return _make_base_curve(curve, pieces, step), next_col


def normal_plane_hits(points, tangents, polyline):
    """Intersections of the normal planes {x : (x - p_j) . t_j = 0} with a polyline (Rajain et al. 2023 Fig. 10).

    points, tangents (N, 3); returns (j (k,), arc length on the polyline (k,), hit points (k, 3)),
    one row per crossing of plane j with a segment (a plane may cross a curved polyline more than
    once)."""
    Q = polyline.points
    sd = (Q @ tangents.T - (points * tangents).sum(1)).T    # (N, n) signed distances to the planes
    scale = float(np.abs(Q).max() + np.abs(points).max())
    sd[np.abs(sd) <= 1e-12 * scale] = 0.0                   # a plane through a vertex (e.g. both ends) hits it
    s0, s1 = sd[:, :-1], sd[:, 1:]
    hit = (((s0 <= 0) & (s1 >= 0)) | ((s0 >= 0) & (s1 <= 0))) & (s0 != s1)
    j, k = np.nonzero(hit)
    u = s0[j, k] / (s0[j, k] - s1[j, k])
    cum = polyline.arclength
    x = Q[k] + u[:, None] * (Q[k + 1] - Q[k])
    return j, cum[k] + u * (cum[k + 1] - cum[k]), x


def _transfer(base, curve, step, max_gap, next_col):
    """Base points of ``curve`` from the normal planes of ``base`` (Fig. 10), plus added points
    where no plane reaches it (Remark 1)."""
    best_d = np.full(len(base.points), np.inf)
    best = [None] * len(base.points)
    for pi, pl in enumerate(curve.polylines):
        j, s, x = normal_plane_hits(base.points, base.tangents, pl)
        if len(j) == 0:
            continue
        d = np.linalg.norm(x - base.points[j], axis=1)
        for jj, ss, dd in zip(j, s, d):     # nearest hit per base point
            if dd < best_d[jj]:
                best_d[jj], best[jj] = dd, (pi, ss)
    pieces = [([], [], []) for _ in curve.polylines]
    for jj in np.flatnonzero(best_d <= max_gap):
        pi, ss = best[jj]
        pieces[pi][0].append(ss), pieces[pi][1].append(base.columns[jj]), pieces[pi][2].append(False)
    out = []
    for pi, pl in enumerate(curve.polylines):
        s = np.asarray(pieces[pi][0], float)
        cols = np.asarray(pieces[pi][1], np.int64)
        add = np.asarray(pieces[pi][2], bool)
        L = pl.length
        if len(s) == 0:
            new = _even_params(0.0, L, step)
        else:
            new = []
            if s.min() > step / 4:
                new.append(_even_params(0.0, s.min(), step)[:-1])
            if L - s.max() > step / 4:
                new.append(_even_params(s.max(), L, step, include_start=False))
            new = np.concatenate(new) if new else np.zeros(0)
        s = np.r_[s, new]
        cols = np.r_[cols, np.arange(next_col, next_col + len(new))]
        add = np.r_[add, np.ones(len(new), bool)]
        next_col += len(new)
        out.append((s, cols, add))
    return _make_base_curve(curve, out, step), next_col


def base_points(curves, step, max_gap, start=0):
    """Base points on all guiding curves and the strips between them (Rajain et al. 2023 §5, Fig. 10, Remarks 1, 3).

    curves: list of :class:`GuidingCurve` in order; step: h, the arc-length step of the base points
    on the start curve (and of added points); max_gap: farthest accepted normal-plane intersection
    from its base point; start: index of the curve seeded first (the paper starts at g_1, i.e. 0);
    from there the normal planes carry the columns to both sides.
    Returns (list of :class:`BaseCurve`, list of :class:`Strip`).
    """
    step, max_gap = float(step), float(max_gap)
    if not (math.isfinite(step) and step > 0):
        raise ValueError(f"base-point step h = {step!r} must be a finite number > 0")
    if not (math.isfinite(max_gap) and max_gap > 0):
        raise ValueError(f"max_gap = {max_gap!r} must be a finite number > 0")
    if not curves:
        return [], []
    total = sum(pl.length for c in curves for pl in c.polylines)
    if total / step > MAX_BASE_POINTS:
        raise ValueError(f"step h = {step:.6g} gives about {total / step:.0f} base points over {total:.6g} of "
                         f"guiding curves, above the limit {MAX_BASE_POINTS}")
    if not 0 <= start < len(curves):
        raise ValueError(f"start = {start} is outside 0..{len(curves) - 1}")
    bases = [None] * len(curves)
    bases[start], col = _seed_curve(curves[start], step, 0)
    for i in range(start + 1, len(curves)):
        bases[i], col = _transfer(bases[i - 1], curves[i], step, max_gap, col)
    for i in range(start - 1, -1, -1):
        bases[i], col = _transfer(bases[i + 1], curves[i], step, max_gap, col)
    strips = []
    for i in range(len(curves) - 1):
        lo, hi = bases[i], bases[i + 1]
        cols, a, b = np.intersect1d(lo.columns, hi.columns, assume_unique=True, return_indices=True)
        o = np.lexsort((lo.arclength[a], lo.piece[a]))
        strips.append(Strip(i, cols[o], a[o], b[o]))
    return bases, strips


# ============================================================================ pipeline
@dataclass
class GuidingCurves:
    """Result of :func:`guiding_curves`: the field, G, the spacing d, the guiding curves g_1..g_(M+1)
    (ascending G), base points per curve, the M strips, the base-point step h, and ``margins``
    (G distance from the lowest G to g_1 and from g_(M+1) to the highest G: the parts of the
    surface outside the outermost curves)."""
    field: GuidingField
    function: GuidingFunction
    spacing: float
    curves: List[GuidingCurve]
    bases: List[BaseCurve]
    strips: List[Strip]
    step: float
    margins: tuple
    timings: dict = dataclass_field(default_factory=dict)


def guiding_curves(vertices, faces, *, direction=None, point=None, field_vectors=None, r1=None, r2=None, L=None,
                   spacing=None, step=None, max_gap=None, method="transport", diffusion_time=None,
                   w_orth=1.0, w_unit=1.0, w_fair=1e-3, scaling="mean", start=0, reuse=None):
    """Guiding curves and base points of Rajain et al. 2023 §5 on a triangle mesh.

    Give the guiding direction either as ``direction`` (3,) at ``point`` (3,) (default: the mesh's
    centre) or as ``field_vectors`` per vertex / per face.  The spacing is ``spacing`` or, from the
    tool, default_spacing(r1, r2, L).  step h defaults to 1/100 of the bounding-box diagonal (§5),
    max_gap to 2 d.  See the module docstring for the method; ``start`` picks the curve whose base
    points are seeded first (0 = g_1 as in the paper).  ``reuse``: a result of this function for the
    same mesh, field, spacing and G options; its field, G and guiding curves are taken as they are and
    only the base points are laid out again (for another ``step``, ``max_gap`` or ``start``).
    """
    import time
    if reuse is not None:
        t0 = time.perf_counter()
        curves = reuse.curves
        V = np.asarray(vertices, float)
        diag = float(np.linalg.norm(V.max(0) - V.min(0)))
        step = diag / 100 if step is None else float(step)
        max_gap = 2 * reuse.spacing if max_gap is None else float(max_gap)
        if curves and not 0 <= start < len(curves):
            raise ValueError(f"start = {start} is outside 0..{len(curves) - 1} ({len(curves)} guiding curves)")
        bases, strips = base_points(curves, step, max_gap, start) if curves else ([], [])
        timings = {"base_points": time.perf_counter() - t0}
        return GuidingCurves(reuse.field, reuse.function, reuse.spacing, curves, bases, strips, step,
                             reuse.margins, timings)
    timings = {}
    t0 = time.perf_counter()
    V, F = validate_mesh(vertices, faces)
    if (direction is None) == (field_vectors is None):
        raise ValueError("give exactly one of direction (one tangent vector at a central point) or field_vectors")
    if spacing is None:
        if r1 is None or r2 is None or L is None:
            raise ValueError("give spacing, or the tool's r1, r2 and L for the default d = sqrt(L^2 - (r2 - r1)^2)")
        spacing = default_spacing(r1, r2, L)
    spacing = float(spacing)
    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    if not (math.isfinite(spacing) and spacing > 0):
        raise ValueError(f"spacing d = {spacing!r} must be a finite number > 0")
    if spacing < 1e-6 * diag:
        raise ValueError(f"spacing d = {spacing:.6g} is below the limit {1e-6 * diag:.6g} (1e-6 x the mesh's "
                         f"bounding-box diagonal)")
    step = diag / 100 if step is None else float(step)
    max_gap = 2 * spacing if max_gap is None else float(max_gap)
    timings["validate"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    N = vertex_normals(V, F)
    if direction is not None:
        fld = _propagate(V, F, direction, point, method, diffusion_time, N)
        src = fld.source
    else:
        fld = field_from_vectors(V, F, field_vectors)
        src = central_vertex(V, F, point)
    timings["field"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    fun = guiding_function(V, F, fld.face, src, w_orth, w_unit, w_fair, scaling)
    timings["function"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    levels = level_values(fun.values, spacing, 0.0)
    edges, face_edges, _ = mesh_edges(F, len(V))
    curves = []
    for lv in levels:
        pls = level_set(V, F, fun.values, lv, N, fld.face, (edges, face_edges))
        if pls:
            curves.append(GuidingCurve(float(lv), pls))
    timings["level_sets"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    if curves and not 0 <= start < len(curves):
        raise ValueError(f"start = {start} is outside 0..{len(curves) - 1} ({len(curves)} guiding curves)")
    bases, strips = base_points(curves, step, max_gap, start) if curves else ([], [])
    timings["base_points"] = time.perf_counter() - t0
    G = fun.values
    margins = ((curves[0].level - G.min(), G.max() - curves[-1].level) if curves else (float(np.ptp(G)), 0.0))
    return GuidingCurves(fld, fun, spacing, curves, bases, strips, step, tuple(float(m) for m in margins), timings)
