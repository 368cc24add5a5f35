"""lodkit: mesh simplification that keeps what people notice.

>>> import lodkit
>>> result = lodkit.simplify(lodkit.load("bunny.ply"), target_ratio=0.1)
>>> lodkit.save(result.mesh, "bunny_10.ply")
"""
from ._signals import import_guard

with import_guard():     # Ctrl-C while the `lodkit` command starts: one line, exit 130
    from . import metrics
    from .api import ErrorBound, SimplifyResult, simplify
    from .batch import BatchResult, batch
    from .cluster import ClusterResult, cluster
    from .compare import Comparison, compare
    from .curvature import point_curvature
    from .errors import (
        Cancelled,
        DependencyError,
        LodkitError,
        MeshError,
        MeshIOError,
        MetricError,
        OptionError,
        UnknownMetricError,
    )
    from .evaluate import Evaluation, Evaluator, evaluate
    from .io import load, save
    from .large import LargeResult, simplify_large
    from .mesh import Mesh
    from .optimize import OptimizeResult, optimize
    from .polish import PolishResult, polish_mesh
    from .progressive import ProgressiveMesh, progressive
    from .retile import RetileResult, retile
    from .topology import TopologyReport, topology
    from .version import __version__ as __version__

__all__ = [
    "BatchResult",
    "Cancelled",
    "DependencyError",
    "ClusterResult",
    "ErrorBound",
    "Comparison",
    "Evaluation",
    "Evaluator",
    "LargeResult",
    "LodkitError",
    "Mesh",
    "MeshError",
    "MeshIOError",
    "MetricError",
    "OptimizeResult",
    "OptionError",
    "PolishResult",
    "ProgressiveMesh",
    "RetileResult",
    "SimplifyResult",
    "TopologyReport",
    "UnknownMetricError",
    "batch",
    "cluster",
    "compare",
    "evaluate",
    "load",
    "metrics",
    "optimize",
    "point_curvature",
    "polish_mesh",
    "progressive",
    "retile",
    "save",
    "simplify",
    "simplify_large",
    "topology",
]
