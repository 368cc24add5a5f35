"""Build the Cython extensions. Everything else lives in pyproject.toml."""
import os

import numpy
from Cython.Build import cythonize
from setuptools import Extension, setup

MODULES = ["heap", "halfedge", "chain", "decimate", "qem_kernel", "melod_kernel", "curvature_kernel",
           "retriangulate", "vremove", "schroeder_kernel", "volume_kernel", "cluster"]
# the public C interface plugins cimport: lodkit/kernel.pxd, lodkit/removal.pxd (lodkit.kernel, ...)
PUBLIC_MODULES = ["kernel", "removal"]
# LODKIT_BUILD_ONLY=a,b builds only those modules (development: others may be mid-edit)
_only = [m for m in os.environ.get("LODKIT_BUILD_ONLY", "").split(",") if m]
if _only:
    MODULES = [m for m in MODULES if m in _only]
    PUBLIC_MODULES = [m for m in PUBLIC_MODULES if m in _only]

extensions = [
    Extension(
        f"{package}.{name}",
        [f"{package.replace('.', '/')}/{name}.pyx"],
        include_dirs=[numpy.get_include()],
        define_macros=[("NPY_NO_DEPRECATED_API", "NPY_1_7_API_VERSION")],
        # -fno-math-errno: sqrt compiles to one instruction (nothing here reads errno)
        extra_compile_args=["-O3", "-fno-math-errno"],
    )
    for package, names in (("lodkit", PUBLIC_MODULES), ("lodkit._core", MODULES))
    for name in names
]

setup(
    ext_modules=cythonize(
        extensions,
        language_level=3,
        compiler_directives={
            "boundscheck": False,
            "wraparound": False,
            "cdivision": True,
            "initializedcheck": False,
            "nonecheck": False,
        },
    ),
)
