"""Build the Cython extensions. Everything else lives in pyproject.toml."""
import os

import numpy
from Cython.Build import cythonize
from setuptools import Extension, setup

MODULES = ["heap", "halfedge", "kernel", "decimate", "qem_kernel", "melod_kernel", "curvature_kernel",
           "removal", "retriangulate", "vremove", "schroeder_kernel", "volume_kernel", "cluster"]
# LODKIT_BUILD_ONLY=a,b builds only those modules (development: others may be mid-edit)
_only = [m for m in os.environ.get("LODKIT_BUILD_ONLY", "").split(",") if m]
if _only:
    MODULES = [m for m in MODULES if m in _only]

extensions = [
    Extension(
        f"lodkit._core.{name}",
        [f"lodkit/_core/{name}.pyx"],
        include_dirs=[numpy.get_include()],
        define_macros=[("NPY_NO_DEPRECATED_API", "NPY_1_7_API_VERSION")],
        # -fno-math-errno: sqrt compiles to one instruction (nothing here reads errno)
        extra_compile_args=["-O3", "-fno-math-errno"],
    )
    for name in MODULES
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
