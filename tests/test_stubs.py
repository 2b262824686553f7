"""The native module's stub (`spheremap/_spheremap.pyi`) matches the built module: every function,
class, method and constant, with its parameters' names, kinds and defaults (mypy's stubtest)."""
import subprocess
import sys

import pytest


def test_native_stub_matches_the_built_module(tmp_path):
    pytest.importorskip("mypy")
    r = subprocess.run([sys.executable, "-m", "mypy.stubtest", "spheremap._spheremap"],
                       capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr


def test_the_package_type_checks(tmp_path):
    """The package's inline annotations are consistent (mypy over the installed package)."""
    pytest.importorskip("mypy")
    r = subprocess.run([sys.executable, "-m", "mypy", "--no-incremental", "--ignore-missing-imports", "-p", "spheremap"],
                       capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
