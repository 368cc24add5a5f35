"""Numpy geometry shared by every lodkit module: face vectors and normals, vertex normals,
triangle quality, welding of coincident positions, plane quadrics, and the Morton order
that lays a mesh out in memory along a space-filling curve.

One home for these, so a face normal means the same thing everywhere: every other module
imports them from here.  Arrays are float64 positions (n, 3) and int faces (m, 3).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["face_vectors", "face_normals", "triangle_quality", "vertex_sums", "vertex_normals",
           "weld_positions", "plane_quadrics", "morton_codes", "morton_order"]


def face_vectors(positions, faces) -> np.ndarray:
    """(m, 3) (b - a) x (c - a) of each face (a, b, c): twice its area times its unit normal."""
    P = np.asarray(positions, dtype=np.float64)
    F = np.asarray(faces)
    return np.cross(P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]])


def face_normals(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(unit normals (m, 3), zero rows for zero-area faces; areas (m,))."""
    n = face_vectors(vertices, np.asarray(faces, dtype=np.int64))
    ln = np.linalg.norm(n, axis=1)
    unit = np.divide(n, ln[:, None], out=np.zeros_like(n), where=ln[:, None] > 0)
    return unit, 0.5 * ln


def triangle_quality(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(m,) Q = 4 sqrt(3) A / (l0^2 + l1^2 + l2^2) in [0, 1]: 1 for an equilateral triangle,
    0 for a zero-area one (faces whose three corners coincide included)."""
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    _, area = face_normals(V, F)
    sq = (np.einsum("ij,ij->i", b - a, b - a) + np.einsum("ij,ij->i", c - b, c - b)
          + np.einsum("ij,ij->i", a - c, a - c))
    q = np.divide(4.0 * math.sqrt(3.0) * area, sq, out=np.zeros_like(sq), where=sq > 0)
    return np.clip(q, 0.0, 1.0)


def vertex_sums(faces, values, n: int) -> np.ndarray:
    """Per vertex, the sum over the faces around it of a per-face value: (m,) -> (n,),
    (m, k) -> (n, k)."""
    idx = np.asarray(faces).reshape(-1)
    vals = np.asarray(values, dtype=np.float64)
    if vals.ndim == 1:
        return np.bincount(idx, np.repeat(vals, 3), minlength=n)
    return np.stack([np.bincount(idx, np.repeat(vals[:, j], 3), minlength=n) for j in range(vals.shape[1])], axis=1)


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(n, 3) area-weighted unit vertex normals (the sum of the face vectors around each
    vertex, normalised); a vertex with no area around it gets (0, 0, 1)."""
    v, f = vertices, faces
    face_n = face_vectors(v, f)
    corner = f.reshape(-1)
    normals = np.stack(
        [np.bincount(corner, weights=np.repeat(face_n[:, c], 3), minlength=v.shape[0]) for c in range(3)], axis=1
    )
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.divide(normals, length, out=np.tile([0.0, 0.0, 1.0], (v.shape[0], 1)), where=length > 0)


def weld_positions(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(distinct positions (k, 3), faces over them (m, 3)): the faces of a mesh cut along its
    attribute seams (one vertex per position and uv), over the positions alone, as the
    shape's topology sees them.  -0.0 and 0.0 are one position."""
    positions, inverse = np.unique(vertices + 0.0, axis=0, return_inverse=True)
    return positions, inverse.reshape(-1)[faces]


def plane_quadrics(P: np.ndarray, faces: np.ndarray, n: int) -> np.ndarray:
    """(n, 10) area-weighted plane quadrics a11 a12 a13 a22 a23 a33 b1 b2 b3 c per vertex:
    each face adds area * (n n^T, d n, d^2) of its plane n.x + d = 0 to its three corners
    (zero-area faces add nothing).  The core's ``vertex_quadrics`` builds the same in Cython
    on the half-edge arrays."""
    p0 = P[faces[:, 0]]
    nrm = face_vectors(P, faces)
    length = np.linalg.norm(nrm, axis=1)
    ok = length > 0
    nrm[ok] /= length[ok, None]
    nrm[~ok] = 0.0
    area = 0.5 * length
    d = -np.einsum("ij,ij->i", nrm, p0)
    parts = [nrm[:, 0] * nrm[:, 0], nrm[:, 0] * nrm[:, 1], nrm[:, 0] * nrm[:, 2], nrm[:, 1] * nrm[:, 1],
             nrm[:, 1] * nrm[:, 2], nrm[:, 2] * nrm[:, 2], d * nrm[:, 0], d * nrm[:, 1], d * nrm[:, 2], d * d]
    corners = faces.T.reshape(-1)
    Q = np.empty((n, 10))
    for k, part in enumerate(parts):
        Q[:, k] = np.bincount(corners, weights=np.tile(area * part, 3), minlength=n)
    return Q


_MORTON_BITS = 21            # per axis: 3 x 21 = 63 bits of one uint64 code


def _spread_bits(x: np.ndarray) -> np.ndarray:
    """The low 21 bits of each x with two zero bits after each one (x = b20..b1b0 ->
    b20 0 0 ... b1 0 0 b0): the axis's share of a 3D Morton code."""
    x = x.astype(np.uint64) & np.uint64(0x1FFFFF)
    for shift, mask in ((32, 0x1F00000000FFFF), (16, 0x1F0000FF0000FF), (8, 0x100F00F00F00F00F),
                        (4, 0x10C30C30C30C30C3), (2, 0x1249249249249249)):
        x = (x | (x << np.uint64(shift))) & np.uint64(mask)
    return x


def morton_codes(points: np.ndarray) -> np.ndarray:
    """(n,) uint64 Morton (Z-order) codes of (n, 3) points, each axis quantised to 2^21
    steps over the points' bounding box: points close in space get close codes, so sorting
    by code puts neighbours near each other in memory."""
    P = np.asarray(points, dtype=np.float64)
    if P.shape[0] == 0:
        return np.zeros(0, dtype=np.uint64)
    lo, hi = P.min(axis=0), P.max(axis=0)
    ext = np.where(hi > lo, hi - lo, 1.0)
    top = float((1 << _MORTON_BITS) - 1)
    q = np.clip((P - lo) / ext * top, 0.0, top).astype(np.uint64)
    return _spread_bits(q[:, 0]) | (_spread_bits(q[:, 1]) << np.uint64(1)) | (_spread_bits(q[:, 2]) << np.uint64(2))


def morton_order(points: np.ndarray) -> np.ndarray:
    """(n,) int32 permutation sorting ``points`` along their Morton curve (ties, such as
    coincident points, keep their order: a stable sort)."""
    return np.argsort(morton_codes(points), kind="stable").astype(np.int32)


def box_diagonal(lo, hi) -> float:
    """Length of the box diagonal ``hi - lo``, without the underflow or overflow of squaring
    the sides: coordinates of 1e-170 or 1e+200 give their true diagonal, not 0 or inf
    (inf only when the diagonal itself is past the float range)."""
    d = np.abs(np.asarray(hi, dtype=np.float64) - np.asarray(lo, dtype=np.float64))
    big = float(d.max()) if d.size else 0.0
    if not (big > 0.0) or not math.isfinite(big):
        return big
    if 1e-150 < big < 1e150:
        return float(np.linalg.norm(d))             # no under- or overflow: the plain formula
    return big * float(np.linalg.norm(d / big))
