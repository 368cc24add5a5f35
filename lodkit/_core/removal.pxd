# cython: language_level=3
"""Deprecated path of the vertex-removal kernel interface: ``cimport lodkit.removal`` instead.

Kept for one release; it re-exports every name of lodkit/removal.pxd (removal kernel API
version 2: rebuild the plugin).  Removed in the next release.
"""
from lodkit.kernel cimport KernelMesh
from lodkit.removal cimport REMOVAL_API_VERSION, MAX_VALENCE, Star, Removal, RemovalKernel
