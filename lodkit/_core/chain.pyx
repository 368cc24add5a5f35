# cython: language_level=3
"""The driver's chain of kernels: see chain.pxd."""
from lodkit.kernel cimport KERNEL_OK, KERNEL_ERROR


cdef class KernelChain:
    """One node of a chain: a kernel and the node after it.  Build one with
    :func:`make_chain`."""

    def __cinit__(self, Kernel kernel not None, KernelChain next=None):
        self.kernel = kernel
        self.next = next

    def kernels(self):
        """The kernels from this node on, in order (a list)."""
        out = []
        cdef KernelChain k = self
        while k is not None:
            out.append(k.kernel)
            k = k.next
        return out


def make_chain(kernels):
    """The chain of ``kernels`` (an iterable of lodkit.kernel.Kernel, in order), or None for
    no kernels.  TypeError for anything that is not a Kernel."""
    kernels = list(kernels)
    cdef KernelChain head = None
    cdef Kernel k
    for obj in reversed(kernels):
        if not isinstance(obj, Kernel):
            raise TypeError(f"kernels must be lodkit.kernel.Kernel instances, got {type(obj).__name__}")
        k = obj
        head = KernelChain(k, head)
    return head


# Recursive: a nogil function may not rebind a typed object variable (reference counts),
# but may pass an attribute on; chains are a few kernels long.

cdef int chain_place(KernelChain k, Candidate* c) noexcept nogil:
    cdef int rc
    if k.kernel.places:
        rc = k.kernel.place(c)
        if rc != KERNEL_OK:
            return rc
    if k.next is not None:
        return chain_place(k.next, c)
    return KERNEL_OK


cdef int chain_cost(KernelChain k, Candidate* c) noexcept nogil:
    cdef int rc = k.kernel.cost(c)
    if rc != KERNEL_OK:
        return rc
    if k.next is not None:
        return chain_cost(k.next, c)
    return KERNEL_OK


cdef int chain_cost_range(KernelChain k, Candidate* c, int skip, int count) noexcept nogil:
    """cost() of ``count`` kernels of the chain, starting ``skip`` kernels past ``k``."""
    cdef int rc
    if skip > 0:
        return chain_cost_range(k.next, c, skip - 1, count)
    rc = k.kernel.cost(c)
    if rc != KERNEL_OK:
        return rc
    if count > 1 and k.next is not None:
        return chain_cost_range(k.next, c, 0, count - 1)
    return KERNEL_OK


cdef int chain_commit(KernelChain k, const Candidate* c) noexcept nogil:
    cdef int rc = k.kernel.commit(c)
    if rc != KERNEL_OK:
        # a collapse that is done cannot be vetoed: anything but OK is an error
        return rc if rc == KERNEL_ERROR else k.kernel.fail(b"commit() must return KERNEL_OK or KERNEL_ERROR")
    if k.next is not None:
        return chain_commit(k.next, c)
    return KERNEL_OK


cdef bint chain_failed(KernelChain k) noexcept nogil:
    if k.kernel.failed:
        return True
    return k.next is not None and chain_failed(k.next)
