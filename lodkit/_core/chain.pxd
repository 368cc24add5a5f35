# cython: language_level=3
"""The kernels of a combined metric, held by the driver (not by the kernels: the public
``Kernel`` layout carries no link, see lodkit/kernel.pxd).

A chain is a singly linked list of ``KernelChain`` nodes, one per kernel, in the metrics'
order; the nogil helpers run place / cost / commit down it and stop at the first answer
other than KERNEL_OK.
"""
from lodkit.kernel cimport Kernel, Candidate


cdef class KernelChain:
    cdef readonly Kernel kernel      # this node's kernel (never None)
    cdef readonly KernelChain next   # the following node, None at the end


cdef int chain_place(KernelChain k, Candidate* c) noexcept nogil
cdef int chain_cost(KernelChain k, Candidate* c) noexcept nogil
cdef int chain_cost_range(KernelChain k, Candidate* c, int skip, int count) noexcept nogil
cdef int chain_commit(KernelChain k, const Candidate* c) noexcept nogil
cdef bint chain_failed(KernelChain k) noexcept nogil
