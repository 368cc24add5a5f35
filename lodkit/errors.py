"""lodkit's exceptions. Each message says what was wrong and where."""


class LodkitError(Exception):
    """Base class of every error lodkit raises on purpose."""


class MeshError(LodkitError, ValueError):
    """The mesh given is not usable: wrong shapes or dtypes, bad indices, NaN/inf, empty."""


class OptionError(LodkitError, ValueError):
    """An option passed to a lodkit function is out of range or inconsistent."""


class MeshIOError(LodkitError, OSError):
    """A mesh file could not be read or written."""
