"""The installed package's metadata: what a package index shows, and that it agrees with the
Rust workspace it is built from (version, licence, repository are declared in Cargo.toml too)."""

import importlib.metadata as md
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def workspace():
    return tomllib.loads((ROOT / "Cargo.toml").read_text())["workspace"]["package"]


def test_the_metadata_a_package_index_shows():
    m = md.metadata("spheremap")
    ws = workspace()
    assert m["Version"] == ws["version"]
    assert m["License-Expression"] == ws["license"]
    assert sorted(m.get_all("License-File")) == ["LICENSE-APACHE", "LICENSE-MIT"]
    urls = dict(u.split(", ", 1) for u in m.get_all("Project-URL"))
    assert urls["Repository"] == ws["repository"]
    assert set(m.get_all("Provides-Extra")) >= {"dask", "viewer"}
    assert m["Requires-Python"] == ">=3.11"
    assert "Typing :: Typed" in m.get_all("Classifier")
    assert m["Summary"] and m["Description-Content-Type"].startswith("text/markdown")
    text = md.distribution("spheremap").read_text("METADATA")
    assert "\n\n# spheremap\n" in text  # the README as the long description


def test_the_installed_files_carry_the_licences_and_the_stub():
    files = {f.name for f in md.files("spheremap")}
    assert {"LICENSE-MIT", "LICENSE-APACHE", "_spheremap.pyi", "py.typed"} <= files


def test_pyproject_declares_what_the_workspace_declares():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    ws = workspace()
    assert project["license"] == ws["license"]
    assert project["urls"]["Repository"] == ws["repository"]
    assert all(u.startswith(ws["repository"]) for u in project["urls"].values())
