"""Deprecated: the native metric interface moved to :mod:`lodkit.kernel` (this alias is
removed in the next release; ``cimport lodkit._core.kernel`` keeps working until then)."""
import warnings

from ..kernel import API_VERSION, ERROR, OK, VETO, Kernel

__all__ = ["API_VERSION", "ERROR", "OK", "VETO", "Kernel"]

warnings.warn("lodkit._core.kernel is deprecated: import (and cimport) lodkit.kernel instead",
              DeprecationWarning, stacklevel=2)
