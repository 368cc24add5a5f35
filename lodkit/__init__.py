"""lodkit: mesh simplification that keeps what people notice.

>>> import lodkit
>>> result = lodkit.simplify(lodkit.load("bunny.ply"), target_ratio=0.1)
>>> lodkit.save(result.mesh, "bunny_10.ply")
"""
from .errors import LodkitError, MeshError, MeshIOError, MetricError, OptionError, UnknownMetricError
from .mesh import Mesh
from .io import load, save
from .api import SimplifyResult, simplify
from .curvature import point_curvature
from .topology import TopologyReport, topology
from . import metrics

__version__ = "0.1.0"

__all__ = [
    "LodkitError",
    "Mesh",
    "MeshError",
    "MeshIOError",
    "MetricError",
    "OptionError",
    "SimplifyResult",
    "TopologyReport",
    "UnknownMetricError",
    "load",
    "metrics",
    "point_curvature",
    "save",
    "simplify",
    "topology",
]
