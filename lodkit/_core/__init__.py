"""Cython core: half-edge arrays, indexed heap, collapse drivers."""
