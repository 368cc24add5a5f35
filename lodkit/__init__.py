"""lodkit: mesh simplification that keeps what people notice.

>>> import lodkit
>>> result = lodkit.simplify(lodkit.load("bunny.ply"), target_ratio=0.1)
>>> lodkit.save(result.mesh, "bunny_10.ply")
"""
from . import metrics
from .api import SimplifyResult, simplify
from .batch import BatchResult, batch
from .cluster import ClusterResult, cluster
from .compare import Comparison, compare
from .curvature import point_curvature
from .errors import DependencyError, LodkitError, MeshError, MeshIOError, MetricError, OptionError, UnknownMetricError
from .evaluate import Evaluation, Evaluator, evaluate
from .io import load, save
from .large import LargeResult, simplify_large
from .mesh import Mesh
from .progressive import ProgressiveMesh, progressive
from .topology import TopologyReport, topology
from .version import __version__ as __version__

__all__ = [
    "BatchResult",
    "DependencyError",
    "ClusterResult",
    "Comparison",
    "Evaluation",
    "Evaluator",
    "LargeResult",
    "LodkitError",
    "Mesh",
    "MeshError",
    "MeshIOError",
    "MetricError",
    "OptionError",
    "ProgressiveMesh",
    "SimplifyResult",
    "TopologyReport",
    "UnknownMetricError",
    "batch",
    "cluster",
    "compare",
    "evaluate",
    "load",
    "metrics",
    "point_curvature",
    "progressive",
    "save",
    "simplify",
    "simplify_large",
    "topology",
]
