"""Benchmark inputs: the shared real meshes and a deterministic generated one.

Every mesh is handed to the benchmark as plain arrays, ``vertices`` (n, 3) float64 and
``faces`` (m, 3) int32, exactly as read (unreferenced vertices are kept: that is what a
user would pass in). ``prepare()`` writes them to an ``.npz`` cache so that the worker
subprocesses only pay an ``np.load`` (no Open3D import, no parsing transients) before the
memory baseline is taken.

Names understood by :func:`load_arrays`:

* the stem of any file in the shared mesh directory (``bunny``, ``igea``, ``fandisk``, ...);
* ``generated<N>`` / ``generated<N>k`` / ``generated<N>m`` -> :func:`generated_mesh` with
  about N faces (``generated1m`` = about one million faces).
"""
from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

MESH_DIR = Path(os.environ.get("LODKIT_MESH_DIR", Path(__file__).resolve().parents[2] / "shared" / "data" / "meshes"))

__all__ = ["MESH_DIR", "generated_mesh", "load_arrays", "prepare", "parse_generated"]


# --------------------------------------------------------------------------------------
# generated mesh
# --------------------------------------------------------------------------------------

def _grid_size(n_faces: int, aspect: float) -> tuple[int, int]:
    """(nu, nv) with 2*nu*nv close to n_faces and nu/nv close to aspect; nu divisible by 12."""
    quads = max(n_faces // 2, 12 * 4)
    nv = max(4, int(round(np.sqrt(quads / aspect))))
    nu = max(12, int(round(quads / nv / 12.0)) * 12)
    return nu, nv


def generated_mesh(n_faces: int = 1_000_000) -> tuple[np.ndarray, np.ndarray]:
    """A closed, manifold, consistently oriented (outward) torus of about ``n_faces`` triangles.

    Deterministic (no random numbers). The tube radius is displaced along the tube normal,
    so the surface never self-intersects (the displacement stays within +-35% of the tube
    radius, and the tube radius is 0.3 of the ring radius). Around the ring (u) there are
    three 120-degree sectors with different features:

    * sector 0 -- creases: ``|sin|`` ridges, sharp V-shaped valleys running across the tube
      and a sharp lengthwise ridge along the tube (derivative discontinuities);
    * sector 1 -- smooth: a few broad Gaussian bumps and low-frequency waves plus a
      low-amplitude high-frequency ripple (fine detail that decimation should remove first);
    * sector 2 -- terraces: six flat steps whose vertical walls lie exactly on grid lines
      (CAD-like sharp 90-degree edges), on a smooth tube.

    The sectors are blended with smooth windows, so the only discontinuities are the
    intended ones. ``nu`` (around the ring) is a multiple of 12, so sector and terrace
    boundaries fall on grid lines. Faces: 2*nu*nv; vertices: nu*nv; genus 1.
    """
    R, r = 1.0, 0.3
    nu, nv = _grid_size(int(n_faces), aspect=R / r)
    iu = np.arange(nu)
    iv = np.arange(nv)
    u = 2.0 * np.pi * iu / nu            # around the ring
    v = 2.0 * np.pi * iv / nv            # around the tube
    U, V = np.meshgrid(u, v, indexing="ij")   # (nu, nv)

    # Smooth sector windows (periodic, partition of unity, each ~1 on its sector centre).
    centres = np.array([1.0, 3.0, 5.0]) * np.pi / 3.0
    w = np.stack([np.exp(4.0 * np.cos(U - c)) for c in centres])
    w /= w.sum(axis=0)

    # sector 0: creases
    crease = 0.10 * (1.0 - np.abs(np.sin(9.0 * U))) - 0.05          # V valleys across the tube
    crease += 0.12 * np.maximum(0.0, 0.6 - np.abs(np.angle(np.exp(1j * (V - np.pi / 2))))) # lengthwise ridge on top

    # sector 1: smooth bumps and waves + fine ripple
    smooth = 0.06 * np.sin(3.0 * U) * np.cos(2.0 * V)
    for k in range(5):                                            # golden-angle bump centres
        cu = 2.0 * np.pi / 3.0 + (k + 0.5) * (2.0 * np.pi / 3.0) / 5.0
        cv = (k * 2.399963229728653) % (2.0 * np.pi)
        du = np.angle(np.exp(1j * (U - cu)))
        dv = np.angle(np.exp(1j * (V - cv)))
        smooth += 0.12 * np.exp(-(du ** 2 + (0.3 * dv) ** 2) / (2 * 0.06 ** 2))
    smooth += 0.006 * np.sin(97.0 * U) * np.sin(41.0 * V)

    # sector 2: terraces aligned with grid lines in u (steps every nu/36 rows, 6 per sector)
    step_len = nu // 36
    step = ((iu // step_len) % 6).astype(np.float64)[:, None] * np.ones((1, nv))
    terrace = 0.045 * (step - 2.5)

    d = w[0] * crease + w[1] * smooth + w[2] * terrace
    d = np.clip(d, -0.35, 0.35)
    rr = r * (1.0 + d)

    x = (R + rr * np.cos(V)) * np.cos(U)
    y = (R + rr * np.cos(V)) * np.sin(U)
    z = rr * np.sin(V)
    vertices = np.stack([x, y, z], axis=-1).reshape(-1, 3)

    # Two triangles per grid quad, both wrapping around; orientation chosen outward.
    a = (iu[:, None] * nv + iv[None, :])
    b = (((iu + 1) % nu)[:, None] * nv + iv[None, :])
    c = (((iu + 1) % nu)[:, None] * nv + ((iv + 1) % nv)[None, :])
    dd = (iu[:, None] * nv + ((iv + 1) % nv)[None, :])
    # alternate the diagonal in a checkerboard so there is no global directional bias
    flip = ((iu[:, None] + iv[None, :]) % 2).astype(bool)
    t1 = np.where(flip[..., None], np.stack([a, b, dd], -1), np.stack([a, b, c], -1))
    t2 = np.where(flip[..., None], np.stack([b, c, dd], -1), np.stack([a, c, dd], -1))
    faces = np.concatenate([t1.reshape(-1, 3), t2.reshape(-1, 3)]).astype(np.int32)
    return np.ascontiguousarray(vertices), np.ascontiguousarray(faces)


def parse_generated(name: str) -> int | None:
    m = re.fullmatch(r"generated(\d+(?:\.\d+)?)([km]?)", name.lower())
    if not m:
        return None
    scale = {"": 1, "k": 1_000, "m": 1_000_000}[m.group(2)]
    return int(round(float(m.group(1)) * scale))


# --------------------------------------------------------------------------------------
# loading and caching
# --------------------------------------------------------------------------------------

def _find_file(name: str) -> Path:
    if Path(name).is_file():
        return Path(name)
    suffixes = {".ply", ".obj", ".off", ".stl", ".glb", ".gltf"}
    hits = sorted(p for p in MESH_DIR.glob(name + ".*") if p.suffix.lower() in suffixes)
    if not hits:
        known = sorted({p.stem for p in MESH_DIR.glob("*") if p.suffix.lower() in {".ply", ".obj", ".off", ".stl"}})
        raise FileNotFoundError(f"no mesh called {name!r} in {MESH_DIR} (known: {', '.join(known)}; or generated<N>)")
    return hits[0]


def load_arrays(name: str) -> tuple[np.ndarray, np.ndarray, str]:
    """(vertices float64 (n,3), faces int32 (m,3), description of the source)."""
    n = parse_generated(name)
    if n is not None:
        V, F = generated_mesh(n)
        return V, F, f"bench.meshes.generated_mesh({n})"
    path = _find_file(name)
    import open3d as o3d  # lazy: 1-2 s import

    m = o3d.io.read_triangle_mesh(str(path))
    V = np.asarray(m.vertices, dtype=np.float64).copy()
    F = np.asarray(m.triangles, dtype=np.int32).copy()
    if F.shape[0] == 0:
        raise ValueError(f"{path}: Open3D read no triangles")
    return V, F, str(path)


def _cache_key(name: str) -> str:
    """Changes whenever the input would: the file's size and mtime, or the generator's code."""
    import hashlib
    import inspect

    n = parse_generated(name)
    if n is not None:
        text = f"{n}:{inspect.getsource(generated_mesh)}:{inspect.getsource(_grid_size)}"
    else:
        st = _find_file(name).stat()
        text = f"{_find_file(name).resolve()}:{st.st_size}:{st.st_mtime_ns}"
    return hashlib.sha256(text.encode()).hexdigest()[:10]


def prepare(name: str, cache_dir: Path) -> Path:
    """Write (once) ``<cache_dir>/<name>-<key>.npz`` with vertices, faces and the source; return its path."""
    cache_dir = Path(cache_dir)
    cache_dir.mkdir(parents=True, exist_ok=True)
    out = cache_dir / f"{name}-{_cache_key(name)}.npz"
    if out.exists():
        return out
    V, F, src = load_arrays(name)
    tmp = cache_dir / f".{name}.tmp.npz"
    np.savez(tmp, vertices=V, faces=F, source=np.array(src))
    os.replace(tmp, out)
    return out


if __name__ == "__main__":  # quick self-check of the generated mesh
    import sys
    import time

    n = int(float(sys.argv[1])) if len(sys.argv) > 1 else 1_000_000
    t = time.perf_counter()
    V, F = generated_mesh(n)
    print(f"generated {len(F)} faces, {len(V)} vertices in {time.perf_counter() - t:.2f} s")
    import open3d as o3d

    m = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(V), o3d.utility.Vector3iVector(F))
    print("edge manifold:", m.is_edge_manifold(allow_boundary_edges=False),
          "vertex manifold:", m.is_vertex_manifold(), "orientable:", m.is_orientable())
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    print("edge face counts:", np.bincount(counts))
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    vol = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0
    print("signed volume (>0 = outward):", vol)
