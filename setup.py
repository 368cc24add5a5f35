"""Build the Cython extensions. Everything else lives in pyproject.toml.

Lean by default (docs/install.md has the figures): the extensions compile in parallel, one job
per core (``LODKIT_BUILD_JOBS=N`` to change), the generated C goes to build/ (not into the
package, nor the wheel), and the shared objects carry no debug information (``-g0``, linked
with ``-s`` on Linux).  ``LODKIT_DEBUG=1`` keeps ``-g`` and the symbols, for gdb or perf.
"""
import os
import sys
import tempfile

import numpy
from Cython.Build import cythonize
from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

MODULES = ["heap", "halfedge", "chain", "quadric", "fields", "bound", "edge", "triangle", "passes", "decimate",
           "qem_kernel", "melod_kernel", "curvature_kernel", "retriangulate", "vremove", "schroeder_kernel",
           "volume_kernel", "cluster", "retile"]
# the public C interface plugins cimport: lodkit/kernel.pxd, lodkit/removal.pxd (lodkit.kernel, ...)
PUBLIC_MODULES = ["kernel", "removal"]


def _with_dependants(names):
    """``names`` and every module that cimports one of them, directly or through another:
    a module compiled against an older .pxd of one it cimports reads its classes with the
    old layout (a crash at run time), so those rebuild too."""
    import re
    here = os.path.dirname(os.path.abspath(__file__))
    pattern = re.compile(r"^\s*from\s+(?:\.|lodkit\._core\.|lodkit\.)(\w+)\s+cimport", re.M)
    uses = {}
    for package, mods in (("lodkit", PUBLIC_MODULES), ("lodkit/_core", MODULES)):
        for m in mods:
            text = ""
            for ext in (".pyx", ".pxd"):
                path = os.path.join(here, package, m + ext)
                if os.path.exists(path):
                    with open(path, encoding="utf-8") as f:
                        text += f.read()
            uses[m] = set(pattern.findall(text))
    wanted = set(names)
    while True:
        more = {m for m, deps in uses.items() if m not in wanted and deps & wanted}
        if not more:
            return wanted
        wanted |= more


# LODKIT_BUILD_ONLY=a,b builds only those modules (development: others may be mid-edit), and
# the modules that cimport them
_only = [m for m in os.environ.get("LODKIT_BUILD_ONLY", "").split(",") if m]
if _only:
    _only = _with_dependants(_only)
    MODULES = [m for m in MODULES if m in _only]
    PUBLIC_MODULES = [m for m in PUBLIC_MODULES if m in _only]

# Modules with OpenMP loops (cython.parallel.prange).  Without OpenMP they build and run
# with one thread, with the same output (docs/performance.md, "Threads").
OPENMP_MODULES = {"passes", "halfedge", "quadric", "edge"}


def openmp_flags():
    """-fopenmp when this compiler builds and links an OpenMP program, else none;
    LODKIT_OPENMP=0 turns it off."""
    if os.environ.get("LODKIT_OPENMP", "1") == "0":
        return []
    from setuptools._distutils.ccompiler import new_compiler
    from setuptools._distutils.errors import CompileError, LinkError
    from setuptools._distutils.sysconfig import customize_compiler

    cc = new_compiler()
    customize_compiler(cc)
    with tempfile.TemporaryDirectory() as tmp:
        src = os.path.join(tmp, "omp_probe.c")
        with open(src, "w") as f:
            f.write("#include <omp.h>\nint main(void) { return omp_get_max_threads() > 0 ? 0 : 1; }\n")
        try:
            objs = cc.compile([src], output_dir=tmp, extra_postargs=["-fopenmp"])
            cc.link_executable(objs, os.path.join(tmp, "omp_probe"), extra_postargs=["-fopenmp"])
        except (CompileError, LinkError, OSError):
            print("lodkit: no OpenMP with this compiler; the pass driver will run one thread")
            return []
    return ["-fopenmp"]


_omp = openmp_flags() if OPENMP_MODULES & set(MODULES) else []


def _jobs() -> int:
    """Parallel compile jobs: $LODKIT_BUILD_JOBS, else the cores this process may use."""
    env = os.environ.get("LODKIT_BUILD_JOBS", "")
    if env.isdigit() and int(env) > 0:
        return int(env)
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


_DEBUG = os.environ.get("LODKIT_DEBUG", "0") not in ("", "0")
# -g0 after Python's own CFLAGS (which carry -g) wins; -s strips the symbol table at link time
_SIZE_COMPILE = [] if _DEBUG else ["-g0"]
_SIZE_LINK = [] if _DEBUG or not sys.platform.startswith("linux") else ["-s"]


class ParallelBuildExt(build_ext):
    """build_ext that compiles the extensions in parallel unless told otherwise (-j N)."""

    def finalize_options(self):
        super().finalize_options()
        if not self.parallel:
            self.parallel = _jobs()

# LODKIT_DEBUG_BUILD=1: a sanitizer build for testing (docs/reliability.md, "Sanitizer build"):
# Cython's bounds and initialisation checks on, AddressSanitizer and
# UndefinedBehaviorSanitizer compiled in, no -O3. Run the tests with the ASan runtime
# (and libstdc++, for Open3D) preloaded, as docs/reliability.md shows.
DEBUG_BUILD = os.environ.get("LODKIT_DEBUG_BUILD", "0") not in ("", "0")
_SANITIZE = ["-fsanitize=address,undefined", "-fno-omit-frame-pointer", "-fno-sanitize-recover=undefined"]
_opt = ["-O1", "-g"] + _SANITIZE if DEBUG_BUILD else ["-O3"]

extensions = [
    Extension(
        f"{package}.{name}",
        [f"{package.replace('.', '/')}/{name}.pyx"],
        include_dirs=[numpy.get_include()],
        define_macros=[("NPY_NO_DEPRECATED_API", "NPY_1_7_API_VERSION")],
        # -fno-math-errno: sqrt compiles to one instruction (nothing here reads errno)
        extra_compile_args=_opt + ["-fno-math-errno"] + ([] if DEBUG_BUILD else _SIZE_COMPILE)
        + (_omp if name in OPENMP_MODULES else []),
        extra_link_args=(_omp if name in OPENMP_MODULES else []) + (_SANITIZE if DEBUG_BUILD else _SIZE_LINK),
    )
    for package, names in (("lodkit", PUBLIC_MODULES), ("lodkit._core", MODULES))
    for name in names
]

setup(
    cmdclass={"build_ext": ParallelBuildExt},
    ext_modules=cythonize(
        extensions,
        # the generated C stays out of the package (and so out of the wheel); a debug build
        # gets its own C files: the checks change the generated code
        build_dir=os.path.join("build", "debug" if DEBUG_BUILD else "cython"),
        nthreads=_jobs(),
        language_level=3,
        compiler_directives={
            "boundscheck": DEBUG_BUILD,
            "wraparound": False,            # negative indices stay C semantics (checked by boundscheck)
            "cdivision": True,
            "initializedcheck": DEBUG_BUILD,
            "nonecheck": False,
        },
    ),
)
