"""tetlap.distributed without MPI: how it finds Debian's petsc4py / slepc4py, and the
one-line ImportError that tells "not installed" from "installed but broken". (The
distributed computations themselves run under mpirun: tests/distributed/run.sh.)"""

from __future__ import annotations

import os
import sys

import pytest

from tetlap import distributed

FAKE = "tetlap_fake4py"


@pytest.fixture
def fake(tmp_path, monkeypatch):
    """A Debian-like layout for a fake module: prefixes .../fake<version>/x-linux-gnu-real."""
    pattern = str(tmp_path / "fakedir" / "fake*" / "*-linux-gnu-real")
    monkeypatch.setitem(distributed._DEBIAN_PREFIXES, FAKE, ("TETLAP_FAKE_DIR", pattern))
    monkeypatch.delenv("TETLAP_FAKE_DIR", raising=False)
    monkeypatch.setattr(sys, "path", list(sys.path))
    monkeypatch.delitem(sys.modules, FAKE, raising=False)

    def install(version, body="VALUE = 1\n"):
        prefix = tmp_path / "fakedir" / f"fake{version}" / "x86_64-linux-gnu-real"
        package = prefix / "lib" / "python3" / "dist-packages" / FAKE
        package.mkdir(parents=True)
        (package / "__init__.py").write_text(body + f"VERSION = {version!r}\n")
        return prefix

    yield install
    sys.modules.pop(FAKE, None)


def test_not_installed_is_one_line_with_the_install_hint(fake):
    with pytest.raises(ImportError) as e:
        distributed._import(FAKE)
    message = str(e.value)
    assert "\n" not in message
    assert message.startswith(f"tetlap.distributed needs {FAKE}, which is not installed")
    assert "apt-get install python3-petsc4py" in message


def test_debian_prefix_found_without_the_variable_newest_version(fake, monkeypatch):
    fake("3.9")
    newest = fake("3.18")  # newer than 3.9 although it sorts first as text
    monkeypatch.setattr(sys, "base_prefix", "/usr")
    module = distributed._import(FAKE)
    assert module.VERSION == "3.18"
    assert os.environ["TETLAP_FAKE_DIR"] == str(newest)


def test_a_set_variable_wins_and_is_named_when_wrong(fake, monkeypatch, tmp_path):
    older = fake("3.9")
    fake("3.18")
    monkeypatch.setattr(sys, "base_prefix", "/usr")
    monkeypatch.setenv("TETLAP_FAKE_DIR", str(older))
    assert distributed._import(FAKE).VERSION == "3.9"
    sys.modules.pop(FAKE)
    monkeypatch.setattr(sys, "path", [p for p in sys.path if "fakedir" not in p])
    monkeypatch.setenv("TETLAP_FAKE_DIR", str(tmp_path / "elsewhere"))
    with pytest.raises(ImportError, match=f"TETLAP_FAKE_DIR=.*elsewhere has no {FAKE}"):
        distributed._import(FAKE)


def test_debian_modules_are_not_loaded_into_another_python(fake, monkeypatch):
    fake("3.18")
    monkeypatch.setattr(sys, "base_prefix", "/opt/python")
    with pytest.raises(ImportError, match="built for /usr/bin/python3"):
        distributed._import(FAKE)
    assert not any("fakedir" in p for p in sys.path)


def test_installed_but_broken_says_why_on_one_line(fake, monkeypatch):
    fake("3.18", body="raise ImportError('libpetsc_real.so.3.18: cannot open\\nshared object')\n")
    monkeypatch.setattr(sys, "base_prefix", "/usr")
    with pytest.raises(ImportError) as e:
        distributed._import(FAKE)
    message = str(e.value)
    assert "\n" not in message
    assert f"{FAKE} is installed (" in message
    assert "but failed to import: ImportError: libpetsc_real.so.3.18: cannot open shared" in message


def test_info_without_mpi4py_raises_a_one_line_import_error(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "mpi4py", None)  # as if it were not installed
    with pytest.raises(ImportError) as e:
        distributed.info(tmp_path / "points.npy", tmp_path / "tets.npy")
    assert "\n" not in str(e.value) and "needs mpi4py, which is not installed" in str(e.value)
