"""The package is typed: the extension's stubs (simserpent/_core.pyi) match the built module
(mypy's stubtest), and the examples pass `mypy --strict` against the installed package."""

from __future__ import annotations

import subprocess
import sys

import pytest

from conftest import REPO

pytest.importorskip("mypy")


def run(args: list[str]) -> subprocess.CompletedProcess[str]:
    # From the repository root: `simserpent` is the installed package (python/ is not on the path).
    return subprocess.run([sys.executable, "-m", *args], cwd=REPO, capture_output=True, text=True)


def test_the_stubs_match_the_extension():
    out = run(["mypy.stubtest", "simserpent._core", "--mypy-config-file", "python/pyproject.toml"])
    assert out.returncode == 0, out.stdout + out.stderr


def test_the_examples_pass_mypy_strict():
    out = run(["mypy", "--config-file", "python/pyproject.toml", "--strict", "python/examples"])
    assert out.returncode == 0, out.stdout + out.stderr
