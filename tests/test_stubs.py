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


def test_the_bindings_carry_no_clippy_allowances():
    # a binding with many arguments takes one structured argument instead (assemble's
    # request and options, vjp's cotangents, the regular functions' problem and budget)
    import pathlib

    src = pathlib.Path(__file__).resolve().parent.parent / "rust" / "py" / "src"
    allowed = [f"{p.name}:{k + 1}" for p in sorted(src.glob("*.rs"))
               for k, line in enumerate(p.read_text().splitlines())
               if "allow(clippy::" in line]
    assert allowed == []
