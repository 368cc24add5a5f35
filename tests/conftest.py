"""Shared test helpers: where the real test meshes live.

The real meshes (bunny, cow, spot, ...; see MANIFEST.md there) are not part of the
repository. They are looked for in the directory named by the environment variable
``LODKIT_TEST_DATA`` or, when it is unset, in ``../shared/data/meshes`` relative to the
repository root. Tests that need them skip, with the reason, when they are absent.

Use the fixture ``mesh_dir`` (a ``pathlib.Path``) or, outside fixtures (parametrised
tests, helpers), the function ``shared_mesh(name)``::

    from conftest import shared_mesh

    def test_bunny():
        mesh = lodkit.load(shared_mesh("bunny.ply"))
"""
from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parent.parent
ENV_VAR = "LODKIT_TEST_DATA"
DEFAULT_MESH_DIR = REPO_ROOT.parent / "shared" / "data" / "meshes"


def shared_mesh_dir() -> Path | None:
    """The real-mesh directory, or None when it does not exist.

    ``$LODKIT_TEST_DATA`` wins when set (and then is the only place looked at), else
    ``<repo root>/../shared/data/meshes``.
    """
    env = os.environ.get(ENV_VAR)
    path = Path(env).expanduser() if env else DEFAULT_MESH_DIR
    return path if path.is_dir() else None


def _missing_dir_reason() -> str:
    env = os.environ.get(ENV_VAR)
    if env:
        return f"real test meshes not found: ${ENV_VAR}={env} is not a directory"
    return (
        f"real test meshes not found at {DEFAULT_MESH_DIR} "
        f"(set ${ENV_VAR} to the directory holding bunny.ply, cow.obj, ...)"
    )


def shared_mesh(name: str) -> Path:
    """Path of the real test mesh ``name`` (e.g. ``"bunny.ply"``); skips the test if absent.

    Returns the path only; load it with ``lodkit.load`` (or Open3D) as the test needs.
    Call it inside a test (it calls ``pytest.skip``), not at module import.
    """
    directory = shared_mesh_dir()
    if directory is None:
        pytest.skip(_missing_dir_reason())
    path = directory / name
    if not path.is_file():
        pytest.skip(f"real test mesh {name} not found in {directory}")
    return path


@pytest.fixture(scope="session")
def mesh_dir() -> Path:
    """The directory of real test meshes (``pathlib.Path``); skips the test if it is absent."""
    directory = shared_mesh_dir()
    if directory is None:
        pytest.skip(_missing_dir_reason())
    return directory


def pytest_sessionfinish(session, exitstatus):
    """Free what the tests left in reference cycles before the interpreter shuts down.

    Open3D counts its tensor allocations and, at exit, turns any still alive into a
    failing exit status (isl-org/Open3D#3666) even though every test passed; objects
    caught in cycles (exceptions with tracebacks, mocks) are only freed by a collection.
    """
    import gc

    gc.collect()


def lodkit_subprocess_env(**extra) -> dict:
    """The environment for a Python subprocess that must import the lodkit under test: the
    installed copy in CI (the source tree there has no compiled extensions), the source tree
    in a development checkout built in place.  Run it with ``cwd`` outside the repository
    (``tmp_path``), or ``python -c`` / ``-m`` would put an unbuilt source tree first."""
    import lodkit

    root = str(Path(lodkit.__file__).resolve().parents[1])
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([root] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    env.update(extra)
    return env
