"""Deprecated: the vertex-removal kernel interface moved to :mod:`lodkit.removal` (this
alias is removed in the next release; ``cimport lodkit._core.removal`` keeps working until
then)."""
import warnings

from ..removal import API_VERSION, MAX_STAR, RemovalKernel

__all__ = ["API_VERSION", "MAX_STAR", "RemovalKernel"]

warnings.warn("lodkit._core.removal is deprecated: import (and cimport) lodkit.removal instead",
              DeprecationWarning, stacklevel=2)
