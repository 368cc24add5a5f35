"""One module per operator of :func:`lodkit.simplify`, each calling its core driver.

Every driver module offers the same names, which ``simplify`` calls in this order:

    FIX_SEAMS                      True when the driver cannot keep an attribute seam closed
                                   (every seam copy is then fixed)
    check(metrics, pair_threshold) raise when the operator cannot run these options
    memory_order(metrics, settings) True when the driver wants the slots in Morton order
    setup(metrics, ctx, work)      the metrics, compiled for the core (lodkit._compile)
    run(work, compiled, settings, *, target, max_error, record, progress) -> lodkit._pipeline.Run
    records(work, run, scale)      the operation record in input vertex indices (record=True)

A new operator is a module here with these names and an entry in :data:`DRIVERS`.
"""
from __future__ import annotations

from . import edge, triangle, vertex_removal

__all__ = ["DRIVERS"]

#: simplify(operator=) -> the driver module that runs it
DRIVERS = {"edge": edge, "triangle": triangle, "vertex_removal": vertex_removal}
