"""Schroeder et al. 1992 vertex decimation (placeholder: being written)."""
from .base import RemovalMetric
from .._core.removal import RemovalKernel


class Schroeder(RemovalMetric):
    """Schroeder et al. 1992 vertex decimation."""

    kernel = RemovalKernel
