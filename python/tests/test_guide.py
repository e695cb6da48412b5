"""The guide's Python API reference is what guide/gen_python_api.py makes from the docstrings."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_the_python_api_reference_matches_the_docstrings():
    page = ROOT / "guide/src/reference/python-api.md"
    done = subprocess.run(
        [sys.executable, str(ROOT / "guide/gen_python_api.py"), "--check", str(page)],
        capture_output=True, text=True,
    )
    assert done.returncode == 0, done.stderr
