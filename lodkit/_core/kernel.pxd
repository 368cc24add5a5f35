# cython: language_level=3
"""Deprecated path of the native metric interface: ``cimport lodkit.kernel`` instead.

Kept for one release so that plugins written against lodkit 0.1.0's path still build; it
re-exports every name of lodkit/kernel.pxd (the layout is that of kernel API version 3:
rebuild the plugin).  Removed in the next release.
"""
from lodkit.kernel cimport (
    HEArrays, he_next, he_prev, he_dest, he_ring_next, he_is_boundary,
    KERNEL_API_VERSION, KERNEL_OK, KERNEL_VETO, KERNEL_ERROR, KERNEL_MESSAGE_SIZE,
    VERTEX_FIXED, VERTEX_BOUNDARY,
    KernelMesh, Candidate, vertex_position, fill_candidate, Kernel,
)
