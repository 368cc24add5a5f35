"""Garland-Heckbert quadric error metric, as a quadric metric and as a native kernel."""
from __future__ import annotations

import numpy as np

from .._core.qem_kernel import QEMKernel
from .base import KernelMetric, MetricContext, QuadricMetric


class QEM(QuadricMetric):
    """Quadric error metric (Garland-Heckbert): area-weighted squared distance to the planes
    of the faces a vertex stands for."""

    description = "Garland-Heckbert quadrics: area-weighted squared distance to the original planes"

    def quadrics(self, ctx: MetricContext) -> np.ndarray:
        # the core computes exactly these for every run; hand them back instead of recomputing
        return ctx.face_quadrics


class QEMNative(KernelMetric):
    """The QEM cost computed by a native kernel through the public kernel interface (same
    result as ``qem``; measures the interface's overhead)."""

    description = "QEM through the native kernel interface (same cost as qem)"
    kernel = QEMKernel
