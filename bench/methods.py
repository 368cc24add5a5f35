"""The simplifiers compared by the benchmark, behind one small interface.

Each method has

* ``probe()``   -> version string; raises (ImportError, AttributeError, ...) if unusable;
* ``setup(V, F, target, ratio)`` -> state: conversion into the library's own input
  format (untimed for "time", included in "time incl. conversion");
* ``call(state)`` -> raw result: **the simplify call only** -- this is what is timed;
* ``extract(state, raw)`` -> (vertices (k,3) float64, faces (j,3) int64): conversion back
  to numpy (untimed for "time").

``V`` is (n,3) float64 and ``F`` is (m,3) int32, as loaded; ``target`` = round(ratio * m).
Parameters are the libraries' defaults except where the brief in bench/README.md says
otherwise (they are listed in ``PARAMS`` and printed into docs/benchmarks.md).
"""
from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]


def _version(dist: str) -> str:
    from importlib.metadata import version

    return version(dist)


# --------------------------------------------------------------------------------------
# lodkit
# --------------------------------------------------------------------------------------

def _lodkit_digest(root: Path | None = None) -> str:
    """Short digest of lodkit's sources and built extensions, to tie numbers to a build."""
    h = hashlib.sha256()
    root = Path(root) if root is not None else REPO / "lodkit"
    for p in sorted(root.rglob("*")):
        if p.suffix in {".py", ".pyx", ".pxd", ".so"} and "__pycache__" not in p.parts:
            h.update(str(p.relative_to(root)).encode())
            h.update(p.read_bytes())
    return h.hexdigest()[:12]


class Lodkit:
    name = "lodkit"
    kwargs: dict = {}

    def probe(self) -> str:
        import lodkit

        if not hasattr(lodkit, "simplify") or not hasattr(lodkit, "Mesh"):
            raise AttributeError("lodkit has no simplify/Mesh")
        where = Path(lodkit.__file__).resolve().parent
        return f"{getattr(lodkit, '__version__', '?')} (src {_lodkit_digest(where)}, {where})"

    def setup(self, V, F, target, ratio):
        import lodkit

        return {"mesh": lodkit.Mesh(V, F), "ratio": ratio}

    def call(self, st):
        import lodkit

        return lodkit.simplify(st["mesh"], target_ratio=st["ratio"], **self.kwargs)

    def extract(self, st, res):
        return np.asarray(res.mesh.vertices, dtype=np.float64), np.asarray(res.mesh.faces, dtype=np.int64)

    def info(self, res) -> dict:
        """Scalar fields of the result (stop reason, achieved error, ...), for the JSON."""
        out = {}
        for k in dir(res):
            if k.startswith("_"):
                continue
            try:
                v = getattr(res, k)
            except Exception:  # noqa: BLE001
                continue
            if isinstance(v, (str, int, float, bool)) or v is None:
                out[k] = v
            elif hasattr(v, "name") and isinstance(v.name, str) and not callable(v):
                out[k] = v.name  # enums
        return out


class LodkitEndpoint(Lodkit):
    name = "lodkit-endpoint"
    kwargs = {"placement": "endpoint"}


# --------------------------------------------------------------------------------------
# peers
# --------------------------------------------------------------------------------------

class Open3D:
    name = "open3d"

    def probe(self):
        import open3d

        try:
            return _version("open3d")
        except Exception:  # noqa: BLE001 - installed as open3d-cpu (lodkit's dependency on Linux x86-64)
            return getattr(open3d, "__version__", "unknown") + " (open3d-cpu)"

    def setup(self, V, F, target, ratio):
        import open3d as o3d

        m = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(V), o3d.utility.Vector3iVector(F))
        return {"mesh": m, "target": target}

    def call(self, st):
        return st["mesh"].simplify_quadric_decimation(target_number_of_triangles=st["target"])

    def extract(self, st, res):
        return np.asarray(res.vertices, dtype=np.float64), np.asarray(res.triangles, dtype=np.int64)


class FastSimplification:
    name = "fast_simplification"

    def probe(self):
        import fast_simplification  # noqa: F401

        return _version("fast-simplification")

    def setup(self, V, F, target, ratio):
        return {"V": V, "F": F, "reduction": 1.0 - ratio}

    def call(self, st):
        import fast_simplification

        return fast_simplification.simplify(st["V"], st["F"], target_reduction=st["reduction"])

    def extract(self, st, res):
        return np.asarray(res[0], dtype=np.float64), np.asarray(res[1], dtype=np.int64)


class Pyfqmr:
    name = "pyfqmr"

    def probe(self):
        import pyfqmr  # noqa: F401

        return _version("pyfqmr")

    def setup(self, V, F, target, ratio):
        import pyfqmr

        s = pyfqmr.Simplify()
        s.setMesh(V, F)
        return {"s": s, "target": target}

    def call(self, st):
        st["s"].simplify_mesh(target_count=st["target"], aggressiveness=7, preserve_border=True, verbose=False)
        return st["s"]

    def extract(self, st, s):
        v, f, _n = s.getMesh()
        return np.asarray(v, dtype=np.float64), np.asarray(f, dtype=np.int64)


class PyMeshLab:
    name = "pymeshlab"

    def probe(self):
        import pymeshlab  # noqa: F401

        return _version("pymeshlab")

    def setup(self, V, F, target, ratio):
        import pymeshlab

        ms = pymeshlab.MeshSet()
        ms.add_mesh(pymeshlab.Mesh(vertex_matrix=V, face_matrix=F))
        return {"ms": ms, "target": target}

    def call(self, st):
        st["ms"].meshing_decimation_quadric_edge_collapse(targetfacenum=st["target"])
        return st["ms"]

    def extract(self, st, ms):
        m = ms.current_mesh()
        return np.asarray(m.vertex_matrix(), dtype=np.float64), np.asarray(m.face_matrix(), dtype=np.int64)


class VTK:
    name = "vtk"

    def probe(self):
        import vtkmodules.vtkFiltersCore  # noqa: F401

        return _version("vtk")

    def setup(self, V, F, target, ratio):
        from vtkmodules.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray
        from vtkmodules.vtkCommonCore import vtkPoints
        from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkPolyData

        pts = vtkPoints()
        pts.SetData(numpy_to_vtk(np.ascontiguousarray(V), deep=True))
        cells = vtkCellArray()
        offsets = np.arange(0, 3 * len(F) + 1, 3, dtype=np.int64)
        cells.SetData(numpy_to_vtkIdTypeArray(offsets, deep=True),
                      numpy_to_vtkIdTypeArray(np.ascontiguousarray(F, dtype=np.int64).ravel(), deep=True))
        pd = vtkPolyData()
        pd.SetPoints(pts)
        pd.SetPolys(cells)
        return {"pd": pd, "reduction": 1.0 - ratio}

    def call(self, st):
        from vtkmodules.vtkFiltersCore import vtkQuadricDecimation

        dec = vtkQuadricDecimation()
        dec.SetInputData(st["pd"])
        dec.SetTargetReduction(st["reduction"])
        dec.Update()
        return dec.GetOutput()

    def extract(self, st, out):
        from vtkmodules.util.numpy_support import vtk_to_numpy

        V = vtk_to_numpy(out.GetPoints().GetData()).astype(np.float64)
        conn = vtk_to_numpy(out.GetPolys().GetConnectivityArray()).astype(np.int64)
        return V, conn.reshape(-1, 3)


class MeshOptimizer:
    name = "meshoptimizer"

    def probe(self):
        import meshoptimizer  # noqa: F401

        return _version("meshoptimizer")

    def setup(self, V, F, target, ratio):
        idx = np.ascontiguousarray(F, dtype=np.uint32).ravel()
        return {"idx": idx, "pos": np.ascontiguousarray(V, dtype=np.float32),
                "dest": np.zeros_like(idx), "target": 3 * target, "V": V}

    def call(self, st):
        from meshoptimizer import simplify

        # target_error=1.0 (relative to the mesh extent): let the face count, not the error, stop it
        return simplify(st["dest"], st["idx"], st["pos"], target_index_count=st["target"], target_error=1.0)

    def extract(self, st, n):
        F = st["dest"][: int(n)].reshape(-1, 3).astype(np.int64)
        used, inv = np.unique(F, return_inverse=True)
        return np.asarray(st["V"][used], dtype=np.float64), inv.reshape(-1, 3)


METHODS = {m.name: m for m in (Lodkit(), LodkitEndpoint(), Open3D(), FastSimplification(), Pyfqmr(),
                                PyMeshLab(), VTK(), MeshOptimizer())}
DEFAULT_METHODS = ["lodkit", "lodkit-endpoint", "open3d", "fast_simplification", "pyfqmr", "pymeshlab"]

# What each method is asked to do, as printed into the report.
PARAMS = {
    "lodkit": "lodkit.simplify(lodkit.Mesh(V, F), target_ratio=r)",
    "lodkit-endpoint": "lodkit.simplify(lodkit.Mesh(V, F), target_ratio=r, placement='endpoint')",
    "open3d": "TriangleMesh.simplify_quadric_decimation(target_number_of_triangles=round(r*m))",
    "fast_simplification": ("fast_simplification.simplify(V, F, target_reduction=1-r)  "
                            "(agg=7, preserve_border=False: defaults)"),
    "pyfqmr": "Simplify.simplify_mesh(target_count=round(r*m), aggressiveness=7, preserve_border=True)",
    "pymeshlab": "MeshSet.meshing_decimation_quadric_edge_collapse(targetfacenum=round(r*m))  (defaults otherwise)",
    "vtk": "vtkQuadricDecimation, SetTargetReduction(1-r)  (defaults otherwise)",
    "meshoptimizer": "meshoptimizer.simplify(target_index_count=3*round(r*m), target_error=1.0, options=0)",
}
