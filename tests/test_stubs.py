"""The hand-written stub of the native module matches it (mypy's stubtest)."""

from __future__ import annotations

import subprocess
import sys

import pytest


@pytest.mark.slow  # mypy's stubtest: 10-15 s
def test_core_stub_matches_the_runtime_module():
    pytest.importorskip("mypy")
    out = subprocess.run([sys.executable, "-m", "mypy.stubtest", "tetlap._core"],
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stdout + out.stderr
