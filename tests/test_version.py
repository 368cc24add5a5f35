"""The version is written once, in pyproject.toml; lodkit reads it from its metadata."""
from __future__ import annotations

import re
from importlib import metadata
from pathlib import Path

import lodkit
import lodkit.version as version

REPO = Path(__file__).resolve().parents[1]


def _pyproject_version() -> str:
    text = (REPO / "pyproject.toml").read_text()
    return re.search(r'^version = "([^"]+)"', text, re.M).group(1)


def test_version_is_pyprojects():
    assert lodkit.__version__ == _pyproject_version() == metadata.version("lodkit")


def test_source_checkout_without_metadata_reads_pyproject(monkeypatch, tmp_path):
    def missing(name):
        raise metadata.PackageNotFoundError(name)

    monkeypatch.setattr(version.metadata, "version", missing)
    # the package next to a pyproject.toml of another project does not take its version
    fake = tmp_path / "lodkit" / "version.py"
    fake.parent.mkdir()
    (tmp_path / "pyproject.toml").write_text('[project]\nname = "other"\nversion = "9.9"\n')
    monkeypatch.setattr(version, "__file__", str(fake))
    assert version._version() == "0+unknown"
    (tmp_path / "pyproject.toml").write_text('[build-system]\nrequires = []\n\n[project]\nname = "lodkit"\n'
                                             'version = "1.2.3"\n\n[tool.x]\nversion = "0"\n')
    assert version._version() == "1.2.3"


def test_no_other_copy_of_the_version_in_the_package():
    v = re.escape(_pyproject_version())
    copies = [p.relative_to(REPO) for p in (REPO / "lodkit").rglob("*.py")
              if re.search(rf'["\']{v}["\']', p.read_text())]
    assert not copies, f"the version is written in {copies}: read lodkit.__version__ instead"
