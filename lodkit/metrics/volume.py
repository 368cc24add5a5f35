"""Chuon and Guha volume-cost vertex decimation (placeholder: being written)."""
from .base import RemovalMetric
from .._core.removal import RemovalKernel


class Volume(RemovalMetric):
    """Chuon and Guha volume-cost vertex decimation."""

    kernel = RemovalKernel
