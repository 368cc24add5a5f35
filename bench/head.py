"""A smooth, mostly convex, head-like surface generated in code (issue 17, the ``volume`` /
``schroeder`` item): the case where memory-less vertex-removal costs shave a dome flat.

An icosahedron whose faces are cut into ``freq``² triangles each (a geodesic sphere of
20 freq² faces, near-uniform triangles, valence 6 except at the 12 corners), projected on
the unit sphere, stretched into an ellipsoid (a head's proportions: taller than wide,
deeper than wide) and given a few gentle bumps (a brow, a nose, cheeks, a chin -- smooth
Gaussian swellings of a few percent of the radius -- and two shallow eye sockets, so most
of the surface stays convex and a few percent of the vertices are saddles),
plus an optional radial noise of a scan (``noise``, a fraction of the radius; uniform
random, seeded).

    head(n_faces=100_000, noise=0.0, seed=0) -> (vertices (n, 3) float64, faces (m, 3) int32)
    head_mesh(...)                           -> lodkit.Mesh

    python bench/head.py                      # sizes and the share of hyperbolic vertices

The surface is closed, oriented outwards, 2-manifold, of genus 0.  ``bench/removal.py``
measures it as ``head100k`` (100k faces, noise 0) and ``head100k_noisy`` (noise 2e-4).
"""
from __future__ import annotations

import math

import numpy as np

#: (direction (unnormalised), amplitude as a fraction of the radius, width in radians)
BUMPS = (
    ((0.0, 1.0, 0.2), 0.10, 0.16),       # nose
    ((0.3, 1.0, 0.4), -0.03, 0.12),      # eye sockets (concave)
    ((-0.3, 1.0, 0.4), -0.03, 0.12),
    ((0.0, 1.0, 0.55), 0.035, 0.55),     # brow
    ((0.45, 0.85, 0.0), 0.025, 0.45),    # cheeks
    ((-0.45, 0.85, 0.0), 0.025, 0.45),
    ((0.0, 0.8, -0.6), 0.04, 0.40),      # chin
    ((0.0, -0.3, 1.0), 0.02, 0.9),       # crown
)
AXES = (0.78, 0.92, 1.0)                  # x (ear to ear), y (face to back), z (up)


def _icosahedron():
    t = (1.0 + math.sqrt(5.0)) / 2.0
    V = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0],
                  [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
                  [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], dtype=np.float64)
    F = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11],
                  [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
                  [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
                  [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]], dtype=np.int64)
    return V / np.linalg.norm(V, axis=1, keepdims=True), F


def geodesic_sphere(freq: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit sphere: every icosahedron face cut into freq² triangles (shared edge vertices
    welded), 10 freq² + 2 vertices and 20 freq² faces, oriented outwards."""
    if freq < 1:
        raise ValueError("freq must be >= 1")
    V0, F0 = _icosahedron()
    # barycentric grid of one face: points (i, j) with i + j <= freq
    ij = [(i, j) for i in range(freq + 1) for j in range(freq + 1 - i)]
    idx = {p: n for n, p in enumerate(ij)}
    tris = []
    for i in range(freq):
        for j in range(freq - i):
            tris.append((idx[(i, j)], idx[(i + 1, j)], idx[(i, j + 1)]))
            if i + j + 1 < freq:
                tris.append((idx[(i + 1, j)], idx[(i + 1, j + 1)], idx[(i, j + 1)]))
    ij = np.array(ij, dtype=np.float64)
    tris = np.array(tris, dtype=np.int64)
    w = np.stack([freq - ij[:, 0] - ij[:, 1], ij[:, 0], ij[:, 1]], axis=1) / freq
    P = np.concatenate([w @ V0[f] for f in F0])
    P /= np.linalg.norm(P, axis=1, keepdims=True)
    F = np.concatenate([tris + n * len(ij) for n in range(len(F0))])
    # weld the copies on the icosahedron's edges and corners (by rounded position)
    key = np.round(P * (8.0 * freq * 1024.0)).astype(np.int64)
    _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    inv = inv.reshape(-1)
    V = P[first]
    F = inv[F]
    # orientation: outwards
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    if np.einsum("ij,ij->i", n, V[F].mean(axis=1)).sum() < 0:
        F = F[:, ::-1]
    return V, np.ascontiguousarray(F, dtype=np.int32)


def head(n_faces: int = 100_000, noise: float = 0.0, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """The head-like surface with about ``n_faces`` faces (20 freq², freq rounded)."""
    freq = max(1, int(round(math.sqrt(n_faces / 20.0))))
    S, F = geodesic_sphere(freq)
    r = np.ones(len(S))
    for d, amp, width in BUMPS:
        d = np.asarray(d, dtype=np.float64)
        d /= np.linalg.norm(d)
        ang = np.arccos(np.clip(S @ d, -1.0, 1.0))
        r += amp * np.exp(-0.5 * (ang / width) ** 2)
    if noise > 0.0:
        r += noise * np.random.default_rng(seed).uniform(-1.0, 1.0, len(S))
    V = S * r[:, None] * np.asarray(AXES)
    return np.ascontiguousarray(V), F


def head_mesh(n_faces: int = 100_000, noise: float = 0.0, seed: int = 0):
    import lodkit

    V, F = head(n_faces, noise, seed)
    return lodkit.Mesh(V, F)


def main() -> int:
    import lodkit
    from lodkit._core.volume_kernel import measure

    for n_faces, noise in ((100_000, 0.0), (100_000, 2e-4), (5_000, 0.0)):
        V, F = head(n_faces, noise)
        m = lodkit.Mesh(V, F)
        # hyperbolic share over a sample of vertices (volume's never-removed ones)
        nbrs = [[] for _ in range(len(V))]
        for a, b, c in F.tolist():
            nbrs[a].append((b, c))
            nbrs[b].append((c, a))
            nbrs[c].append((a, b))
        rng = np.random.default_rng(1)
        sample = rng.choice(len(V), size=min(2000, len(V)), replace=False)
        hyp = 0
        for v in sample:
            nxt = dict(nbrs[v])
            ring = [nbrs[v][0][0]]
            while len(ring) < len(nxt):
                ring.append(nxt[ring[-1]])
            hyp += measure(V[v], V[ring])["class"] == "hyperbolic"
        print(f"head({n_faces}, noise={noise:g}): {m.n_vertices} vertices, {m.n_faces} faces, "
              f"hyperbolic {hyp / len(sample):.1%}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
