"""Build the native kernel against the lodkit that is installed.

Cython finds ``lodkit/kernel.pxd`` (lodkit installs its .pxd files as package data)
through the include path given here: the directory holding the installed ``lodkit``
package, wherever and however it was installed (site-packages, editable, a source tree).
"""
import importlib.util
import os

from Cython.Build import cythonize
from setuptools import Extension, setup


def lodkit_include_dir() -> str:
    spec = importlib.util.find_spec("lodkit")
    if spec is None or not spec.submodule_search_locations:
        raise SystemExit("lodkit-max-edge: lodkit is not installed in this environment; install lodkit "
                         "first, then this plugin with `pip install --no-build-isolation`")
    package_dir = list(spec.submodule_search_locations)[0]
    if not os.path.isfile(os.path.join(package_dir, "kernel.pxd")):
        raise SystemExit(f"lodkit-max-edge: {package_dir} has no kernel.pxd; this lodkit is older than "
                         f"the kernel interface at lodkit/kernel.pxd (kernel API 3) this plugin is written for")
    return os.path.dirname(package_dir)


extensions = [
    Extension(
        "lodkit_max_edge._kernel",
        ["src/lodkit_max_edge/_kernel.pyx"],
        extra_compile_args=["-O3"],
    )
]

setup(
    ext_modules=cythonize(
        extensions,
        include_path=[lodkit_include_dir()],
        language_level=3,
        compiler_directives={"boundscheck": False, "wraparound": False, "cdivision": True},
    ),
)
