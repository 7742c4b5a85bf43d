"""The README is the front page: what tetlap is, the two commands, one example, a picture,
the "which operator?" table and links into the guide, each of which exists. Its examples
run as written, with the guide's runner (tests/test_guide.py): every ```python block on
its own and every ```pycon block as a doctest, so the numbers it shows are the ones the
code prints."""

from __future__ import annotations

import importlib.util
import os
import pathlib
import re

import numpy as np
import pytest
from test_docs_reference import JOBS
from test_guide import code_blocks, run_block

ROOT = pathlib.Path(__file__).resolve().parent.parent
README = ROOT / "README.md"


def test_the_readme_has_an_example():
    assert [p.values[0] for p in code_blocks(README)].count("pycon") >= 1


@pytest.mark.parametrize("kind, code, path", code_blocks(README))
def test_readme_block_runs_as_written(kind, code, path):
    run_block(kind, code, path)


def test_the_readme_is_a_front_page():
    """Its sections are the front page's, and nothing else: the rest lives in the guide."""
    text = README.read_text()
    assert re.findall(r"^## (.*)$", text, re.MULTILINE) == [
        "Two commands", "Example", "Which operator?", "Documentation"]
    assert "pip install . && tetlap info" in text
    assert 'cargo test --workspace && python -m pytest -m "slow or not slow"' in text


def test_every_link_and_picture_of_the_readme_exists():
    """Relative links and images name files of the repository (GitHub shows them), the
    picture is a PNG under docs/, and every page of the guide is linked."""
    text = README.read_text()
    images = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text)
    links = re.findall(r"(?<!!)\[[^\]]*\]\(([^)#]+)(?:#[^)]*)?\)", text)
    assert len(images) == 1 and images[0].startswith("docs/") and images[0].endswith(".png")
    assert (ROOT / images[0]).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    for target in links:
        assert not target.startswith(("/", "http")), target
        assert (ROOT / target).exists(), f"README links to {target}, which does not exist"
    assert {f"docs/guide/{job}.md" for job in JOBS} <= set(links)


def test_the_site_shows_the_front_page_and_the_table_once():
    """The site's index and the guide's "which operator?" page include the README's
    parts between its markers, rather than copies of them."""
    text = README.read_text()
    for marker in ("front-page", "which-operator"):
        assert text.count(f"<!-- {marker} -->") == 1 and text.count(f"<!-- /{marker} -->") == 1
    index = (ROOT / "docs" / "index.md").read_text()
    guide = (ROOT / "docs" / "guide" / "which-operator.md").read_text()
    assert ":start-after: <!-- front-page -->" in index
    assert ":start-after: <!-- which-operator -->" in guide


def test_independent_of_orientation_numbering_and_order_to_rounding():
    """The first bullet: a reoriented, renumbered and reordered mesh gives operators that
    differ by less than 1e-13 of their largest entry (measured: 2e-14 on the hammer)."""
    import tetlap

    text = " ".join(README.read_text().split())
    assert ("to rounding, not bitwise: a reoriented, renumbered or reordered mesh gives "
            "operators that differ by less than `1e-13` of their largest entry") in text
    meshes = [tetlap.meshes.cube(6, jitter=0.25, seed=1), tetlap.meshes.weighted_ball(800, 1.0)]
    hammer = pathlib.Path(os.environ.get("TETLAP_MESHES", "")) / "ipc_hammer.msh"
    if hammer.is_file() and importlib.util.find_spec("meshio"):
        import tetlap.io

        meshes.append(tetlap.io.read(hammer))
    rng = np.random.default_rng(0)
    for V, T in meshes:
        perm = rng.permutation(len(V))
        new = np.empty_like(perm)
        new[perm] = np.arange(len(V))
        T2 = new[T][rng.permutation(len(T))]
        flip = rng.random(len(T2)) < 0.5
        T2[flip] = T2[flip][:, [1, 0, 2, 3]]
        for kind in ("primal", "dual"):
            A = tetlap.laplacian(V, T, kind)
            B = tetlap.laplacian(V[perm], T2, kind)[np.ix_(new, new)]
            assert abs(A - B).max() < 1e-13 * abs(A).max(), kind
        for kind in ("barycentric", "circumcentric"):
            a = tetlap.mass(V, T, kind).diagonal()
            b = tetlap.mass(V[perm], T2, kind).diagonal()[new]
            assert np.abs(a - b).max() < 1e-13 * np.abs(a).max(), kind
