"""Cython modules the tests need but lodkit does not ship, built once per checkout.

``load("lodkit_testkernels")`` compiles ``tests/native/lodkit_testkernels.pyx`` against the
lodkit that ``import lodkit`` finds (its ``.pxd`` files: the installed package, or the source
tree when it is first on ``sys.path``) and imports it.  The build goes to a cache directory
keyed by the sources, the ``.pxd`` files, Python, Cython and numpy, so it runs once (10-20 s)
and again only when one of them changes:

    $LODKIT_TEST_BUILD_DIR           when set
    <tempdir>/lodkit-test-build-<user>   otherwise

It needs Cython, setuptools and a C compiler (the ``[test]`` extra brings the first two).
Used by the tests (``from native import load``) and by bench/metrics.py.
"""
from __future__ import annotations

import getpass
import hashlib
import importlib.util
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent

_SETUP = """\
import sys
import numpy
from Cython.Build import cythonize
from setuptools import Extension, setup

name, source, include = sys.argv[1:4]
del sys.argv[1:4]
setup(
    name=name,
    script_args=sys.argv[1:],
    ext_modules=cythonize(
        [Extension(name, [source], include_dirs=[numpy.get_include()],
                   define_macros=[("NPY_NO_DEPRECATED_API", "NPY_1_7_API_VERSION")],
                   extra_compile_args=["-O1"])],
        include_path=[include], language_level=3, quiet=True,
        compiler_directives={"boundscheck": False, "wraparound": False, "cdivision": True},
    ),
)
"""


class NativeBuildError(RuntimeError):
    """A test-only Cython module could not be built (the message holds the compiler output)."""


def _lodkit_root() -> Path:
    """The directory holding the ``lodkit`` package the tests import (what cimports resolve to)."""
    spec = importlib.util.find_spec("lodkit")
    if spec is None or spec.origin is None:
        raise NativeBuildError("lodkit is not importable: install it (pip install '.[test]') first")
    return Path(spec.origin).resolve().parent.parent


def _cache_dir() -> Path:
    env = os.environ.get("LODKIT_TEST_BUILD_DIR")
    if env:
        return Path(env).expanduser()
    try:
        user = getpass.getuser()
    except Exception:                     # no user name (some containers): the uid will do
        user = str(os.getuid()) if hasattr(os, "getuid") else "user"
    return Path(tempfile.gettempdir()) / f"lodkit-test-build-{user}"


def _key(source: Path, root: Path) -> str:
    """Digest of everything the compiled module depends on."""
    import Cython
    import numpy

    h = hashlib.sha256()
    h.update(source.read_bytes())
    for pxd in sorted((root / "lodkit").rglob("*.pxd")):
        h.update(str(pxd.relative_to(root)).encode())
        h.update(pxd.read_bytes())
    for part in (str(root), sys.version, sysconfig.get_platform(), Cython.__version__, numpy.__version__):
        h.update(part.encode())
    return h.hexdigest()[:16]


def _find_built(directory: Path, name: str) -> Path | None:
    suffix = sysconfig.get_config_var("EXT_SUFFIX") or ".so"
    path = directory / f"{name}{suffix}"
    return path if path.is_file() else None


def build(name: str, source: Path | None = None) -> Path:
    """Build ``tests/native/<name>.pyx`` (or ``source``) if its cached build is stale and return
    the directory holding the extension module; raises NativeBuildError with the compiler's
    output if it does not build."""
    source = Path(source) if source is not None else HERE / f"{name}.pyx"
    if not source.is_file():
        raise NativeBuildError(f"no test module source {source}")
    try:
        import Cython  # noqa: F401
        import setuptools  # noqa: F401
    except ImportError as e:
        raise NativeBuildError(f"building the test-only module {name} needs Cython and setuptools "
                               f"(pip install '.[test]'): {e}") from None
    root = _lodkit_root()
    target = _cache_dir() / f"{name}-{_key(source, root)}"
    if _find_built(target, name):
        return target
    target.parent.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix=f"{name}-", dir=target.parent))
    script = work / "setup_native.py"
    script.write_text(_SETUP)
    # a copy of the source in the work directory: Cython writes the .c next to it
    copy = work / source.name
    copy.write_bytes(source.read_bytes())
    cmd = [sys.executable, str(script), name, str(copy), str(root), "build_ext",
           "--build-lib", str(work / "lib"), "--build-temp", str(work / "tmp")]
    proc = subprocess.run(cmd, cwd=work, capture_output=True, text=True)
    built = _find_built(work / "lib", name)
    if proc.returncode != 0 or built is None:
        tail = "\n".join((proc.stdout + proc.stderr).splitlines()[-40:])
        raise NativeBuildError(
            f"could not build the test-only Cython module {name} from {source} against the lodkit "
            f"in {root} (exit {proc.returncode}; the build is in {work}):\n{tail}")
    try:
        os.replace(work / "lib", target)   # atomic: a concurrent session may have won the race
    except OSError:
        if not _find_built(target, name):
            raise
    shutil.rmtree(work, ignore_errors=True)
    return target


def load(name: str = "lodkit_testkernels"):
    """Build (if needed) and import the test-only module ``name``."""
    if name in sys.modules:
        return sys.modules[name]
    directory = build(name)
    path = _find_built(directory, name)
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module
