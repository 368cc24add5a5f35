"""The metric registry: every cost metric, lodkit's own and third parties', by name.

Metrics are found in the entry-point group ``lodkit.metrics``; lodkit's built-ins are
registered there by lodkit's own ``pyproject.toml``, as a plugin package would.  Entry
points are listed without importing them; a metric is imported the first time it is used.
A plugin that fails to import, or gives something that is not a metric, is reported by
:func:`available` (name, package, version, error) and never breaks the others.

    available(load=False) -> [MetricInfo]   every metric found
    get(name)             -> Metric class   imported on first use
    create(spec)          -> [Metric]       instances from "qem", ("curvature", {...}), ...
    register(name, cls)                     an in-process metric (tests, notebooks)

Set ``LODKIT_METRICS_DISCOVERY=0`` to skip entry-point discovery: only lodkit's built-ins
and :func:`register`-ed metrics are then available (the test suite uses it to isolate runs).
A name provided by two packages is ambiguous: ask for ``"package:name"``.  lodkit's own
names win over a third party's, which stays reachable as ``"package:name"``.
"""
from __future__ import annotations

import importlib
import os
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from importlib import metadata
from typing import Any

from ..errors import MetricError, OptionError, UnknownMetricError
from ..kernel import API_VERSION as KERNEL_API
from ..removal import API_VERSION as REMOVAL_API
from ..version import __version__
from .base import (
    ATTRIBUTE_WIDTHS,
    KINDS,
    Batch,
    BatchMetric,
    FieldMetric,
    KernelMetric,
    Metric,
    MetricContext,
    Option,
    QuadricMetric,
    RemovalMetric,
    check_metric_class,
    pack_quadrics,
    packed_size,
    unpack_quadrics,
)

__all__ = [
    "GROUP", "DISCOVERY_ENV", "MetricInfo", "available", "get", "create", "register",
    "unregister", "refresh", "Metric", "QuadricMetric", "FieldMetric", "KernelMetric",
    "BatchMetric", "RemovalMetric", "Option", "MetricContext", "Batch", "KINDS", "ATTRIBUTE_WIDTHS",
    "pack_quadrics", "unpack_quadrics", "packed_size",
]

GROUP = "lodkit.metrics"
DISCOVERY_ENV = "LODKIT_METRICS_DISCOVERY"
_OWN = "lodkit"

# lodkit's own metrics: the same table as [project.entry-points."lodkit.metrics"] in
# pyproject.toml (a test keeps them equal).  Used when lodkit runs from a source tree
# without installed metadata, and when discovery is switched off.
BUILTINS = {
    "qem": "lodkit.metrics.qem:QEM",
    "qem_native": "lodkit.metrics.qem:QEMNative",
    "importance": "lodkit.metrics.importance:Importance",
    "melod": "lodkit.metrics.melod:MELOD",
    "normal_qem": "lodkit.metrics.normal_qem:NormalQEM",
    "curvature": "lodkit.metrics.curvature:Curvature",
    "appearance": "lodkit.metrics.appearance:Appearance",
    "schroeder": "lodkit.metrics.schroeder:Schroeder",
    "volume": "lodkit.metrics.volume:Volume",
}


@dataclass
class MetricInfo:
    """One registered metric, as :func:`available` reports it.

    loaded : True (imported and well-formed), False (failed: see ``error``), None (not tried)
    source : "entry point", "built-in" (lodkit's table, no metadata) or "register"
    """

    name: str
    package: str
    version: str
    target: str
    source: str
    loaded: bool | None = None
    kind: str | None = None
    description: str = ""
    error: str | None = None

    @property
    def qualified(self) -> str:
        return f"{self.package}:{self.name}"


class _Entry:
    def __init__(self, info: MetricInfo, loader: Callable[[], Any]):
        self.info = info
        self.loader = loader
        self.cls: type | None = None

    def load(self) -> type | None:
        if self.info.loaded is not None:
            return self.cls
        try:
            obj = self.loader()
        except Exception as exc:  # a broken plugin must not break the others
            self.info.loaded = False
            self.info.error = f"import failed: {type(exc).__name__}: {exc}"
            if "size changed" in str(exc):         # Cython's check of a base type's layout
                self.info.error += (f" (the plugin was compiled against another lodkit; this one has kernel API "
                                    f"version {KERNEL_API}, removal kernel API version {REMOVAL_API}: rebuild "
                                    f"the plugin against it, e.g. pip install --no-build-isolation --force-reinstall)")
            return None
        problem = check_metric_class(obj)
        if problem:
            self.info.loaded = False
            self.info.error = f"{self.info.target} {problem}"
            return None
        self.cls = obj
        self.info.loaded = True
        self.info.kind = obj.kind
        self.info.description = (obj.description or (obj.__doc__ or "").strip().split("\n")[0]).strip()
        return obj


_entries: dict[str, list[_Entry]] | None = None
_registered: dict[str, _Entry] = {}


def _discovery_on() -> bool:
    return os.environ.get(DISCOVERY_ENV, "1").strip().lower() not in ("0", "off", "false", "no")


def _entry_points() -> Iterable[Any]:
    """The ``lodkit.metrics`` entry points of the installed distributions (tests replace this)."""
    return metadata.entry_points(group=GROUP)


def _lodkit_version() -> str:
    return __version__


def _import_target(target: str) -> Callable[[], Any]:
    def load():
        module, _, attr = target.partition(":")
        obj = importlib.import_module(module.strip())
        for part in attr.strip().split(".") if attr else ():
            obj = getattr(obj, part)
        return obj

    return load


def _discover() -> dict[str, list[_Entry]]:
    found: dict[str, list[_Entry]] = {}
    have_own = False
    if _discovery_on():
        seen = set()
        for ep in _entry_points():
            dist = getattr(ep, "dist", None)
            package = dist.metadata["Name"] if dist is not None and dist.metadata["Name"] else "?"
            version = dist.version if dist is not None else "?"
            key = (ep.name, package, ep.value)
            if key in seen:            # the same distribution seen twice on sys.path
                continue
            seen.add(key)
            if _normal(package) == _OWN:
                have_own = True
            info = MetricInfo(ep.name, package, version, ep.value, "entry point")
            found.setdefault(ep.name, []).append(_Entry(info, ep.load))
    if not have_own:
        version = _lodkit_version()
        for name, target in BUILTINS.items():
            info = MetricInfo(name, _OWN, version, target, "built-in")
            found.setdefault(name, []).insert(0, _Entry(info, _import_target(target)))
    for entries in found.values():
        # lodkit's own first, then the others by package name: a stable order
        entries.sort(key=lambda en: (_normal(en.info.package) != _OWN, _normal(en.info.package)))
    return found


def _normal(package: str) -> str:
    return package.lower().replace("_", "-")


def _all() -> dict[str, list[_Entry]]:
    global _entries
    if _entries is None:
        _entries = _discover()
    return _entries


def refresh() -> None:
    """Forget what was discovered (and loaded); the next call looks again."""
    global _entries
    _entries = None


def register(name: str, cls: type, *, replace: bool = False) -> None:
    """Register a metric class under ``name`` for this process (it takes precedence over
    entry points of the same name).  Raises if the name is taken, unless ``replace``."""
    if not isinstance(name, str) or not name or ":" in name:
        raise OptionError(f"a metric name must be a non-empty string without ':', got {name!r}")
    problem = check_metric_class(cls)
    if problem:
        raise MetricError(f"cannot register {name!r}: {getattr(cls, '__name__', cls)!s} {problem}")
    if not replace and (name in _registered or name in _all()):
        raise MetricError(f"a metric named {name!r} is already registered; pass replace=True to shadow it")
    module = getattr(cls, "__module__", "?")
    info = MetricInfo(name, module.split(".")[0], "", f"{module}:{cls.__qualname__}", "register")
    entry = _Entry(info, lambda: cls)
    entry.load()
    _registered[name] = entry


def unregister(name: str) -> None:
    """Remove a metric added with :func:`register`."""
    if name not in _registered:
        raise UnknownMetricError(f"no metric {name!r} was registered in this process")
    del _registered[name]


def available(load: bool = False) -> list[MetricInfo]:
    """Every metric found, sorted by name; with ``load=True`` each is imported first so
    that ``kind`` and ``error`` are filled in (a failure is reported, not raised)."""
    out = []
    names = set(_all()) | set(_registered)
    for name in sorted(names):
        entries = ([_registered[name]] if name in _registered else []) + _all().get(name, [])
        for entry in entries:
            if load:
                entry.load()
            out.append(entry.info)
    return out


def _names_hint() -> str:
    names = sorted(set(_all()) | set(_registered))
    return ", ".join(names) if names else "(none)"


def get(name: str) -> type:
    """The metric class registered as ``name`` (or ``"package:name"``), imported now if it
    was not yet.  Raises UnknownMetricError (listing the available names) or MetricError
    (the plugin failed to load, or the name is ambiguous)."""
    if not isinstance(name, str):
        raise OptionError(f"a metric name must be a string, got {name!r}")
    package = None
    if ":" in name:
        package, _, name = name.partition(":")
    entries = _all().get(name, [])
    if name in _registered:
        entries = [_registered[name]] if package is None else [_registered[name]] + entries
    if package is not None:
        entries = [e for e in entries if _normal(e.info.package) == _normal(package)]
        if not entries:
            raise UnknownMetricError(f"package {package!r} provides no metric {name!r}; available: {_names_hint()}")
    if not entries:
        raise UnknownMetricError(f"unknown metric {name!r}; available: {_names_hint()}")
    if package is None and len(entries) > 1 and _normal(entries[0].info.package) != _OWN:
        which = ", ".join(f"{e.info.package} {e.info.version}".strip() for e in entries)
        choices = " or ".join(repr(e.info.qualified) for e in entries)
        raise MetricError(f"metric {name!r} is provided by several packages ({which}); ask for {choices}")
    entry = entries[0]
    cls = entry.load()
    if cls is None:
        raise MetricError(f"metric {name!r} from package {entry.info.package} {entry.info.version} "
                          f"cannot be used: {entry.info.error}".replace("  ", " "))
    return cls


def create(spec: Any) -> list[Metric]:
    """Metric instances from a spec: a name, ``(name, {options})``, a Metric instance or
    class, or a list of those.  Options are validated here (OptionError on a bad one)."""
    if spec is None:
        raise OptionError("metric must be a name, (name, options), a Metric, or a list of those")
    items = list(spec) if isinstance(spec, list) else [spec]
    if not items:
        raise OptionError("metric=[] names no metric")
    out = []
    for item in items:
        if isinstance(item, Metric):
            out.append(item)
            continue
        options: dict = {}
        if isinstance(item, tuple):
            if len(item) != 2 or not isinstance(item[1], dict):
                raise OptionError(f"a metric with options is written (name, {{option: value}}), got {item!r}")
            item, options = item
        if isinstance(item, type):
            problem = check_metric_class(item)
            if problem:
                raise MetricError(f"{item.__name__} {problem}")
            cls, name = item, item.__name__
        else:
            cls = get(item)
            name = item.partition(":")[2] or item
        instance = cls.__new__(cls)
        instance.name = name
        instance.__init__(**options)
        out.append(instance)
    return out
