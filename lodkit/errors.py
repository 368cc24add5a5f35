"""lodkit's exceptions. Each message says what was wrong and where."""


class LodkitError(Exception):
    """Base class of every error lodkit raises on purpose."""


class MeshError(LodkitError, ValueError):
    """The mesh given is not usable: wrong shapes or dtypes, bad indices, NaN/inf, empty."""


class OptionError(LodkitError, ValueError):
    """An option passed to a lodkit function is out of range or inconsistent."""


class MeshIOError(LodkitError, OSError):
    """A mesh file could not be read or written."""


class DataLossWarning(UserWarning):
    """:func:`lodkit.save` left out something the mesh carries because the file format cannot
    hold it (e.g. normals in STL, alpha in OBJ); the message says what."""


class MetricError(LodkitError, RuntimeError):
    """A metric plugin could not be loaded, has the wrong shape, or failed during a run.
    The message names the metric and the package that provides it."""


class UnknownMetricError(OptionError, LookupError):
    """No metric of that name is registered (a bad ``metric=`` option); the message lists
    the available ones."""


class RenderError(LodkitError, RuntimeError):
    """The renderer asked for cannot draw here (Open3D's renderer did not start or failed)."""


class ImageIOError(LodkitError, OSError):
    """An image file could not be written."""


class DependencyError(LodkitError, ImportError):
    """A library lodkit needs cannot be imported: not installed (an optional extra, e.g.
    ``pip install 'lodkit[dask]'``), or (Open3D) a system library it links against is
    missing.  The message says what to install."""


class Cancelled(LodkitError):
    """The run was cancelled: a ``progress=`` callable returned False.  Nothing was written
    and the input is unchanged."""
