"""The test-only Cython modules (tests/native): built against the imported lodkit, cached,
and a clear error when the source does not compile."""
from __future__ import annotations

import importlib.util

import pytest

from native import NativeBuildError, build, load


def test_testkernels_build_against_the_imported_lodkit():
    mod = load("lodkit_testkernels")
    from lodkit._core.kernel import Kernel

    assert issubclass(mod.VetoAll, Kernel)
    assert importlib.util.find_spec("lodkit._core.testkernels") is None     # not shipped in the package


def test_a_broken_source_names_the_module_and_the_compiler_output(tmp_path, monkeypatch):
    monkeypatch.setenv("LODKIT_TEST_BUILD_DIR", str(tmp_path / "cache"))
    src = tmp_path / "broken_kernel.pyx"
    src.write_text("from lodkit._core.kernel cimport NoSuchName\n")
    with pytest.raises(NativeBuildError, match=r"(?s)broken_kernel.*NoSuchName"):
        build("broken_kernel", src)
