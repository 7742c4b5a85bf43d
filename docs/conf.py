"""Sphinx configuration of tetlap's documentation: the user guide, the gallery and the API
reference, built by .ci/run with warnings as errors and the gallery executed:

    python -m sphinx -W -b html docs target/docs

Choices, each the scientific-Python ecosystem's usual one:

* Theme: the PyData Sphinx theme, the one of NumPy, SciPy, scikit-learn, MNE and PyVista,
  so tetlap's users find the navigation they know (guide, gallery and API in the top bar,
  the page's sections on the right).
* Gallery: sphinx-gallery, which PyVista, scikit-learn and MNE use: each example is a
  plain script a user can download and run, executed on every build (a stale example
  fails the build), with its figure and its output, and each API entry links back to the
  examples that use it (``minigallery``).
* Pictures: matplotlib's Agg backend, headless and deterministic with no OpenGL: PyVista's
  off-screen rendering works on this machine only through VTK's fallback after a failed X
  connection (with a warning), which depends on the machine's GL libraries.
* Markdown pages (the guide, and BENCHMARKS.md, SCALING.md, EXPERIMENTS.md and
  CHANGELOG.md included as pages) through MyST.
"""

from __future__ import annotations

import argparse
import os
import sys

from docutils import nodes
from docutils.parsers.rst import Directive
from sphinx.errors import PycodeError
from sphinx.pycode import ModuleAnalyzer
from sphinx.util import logging

import tetlap

logger = logging.getLogger(__name__)

project = "tetlap"
author = "The tetlap developers"
copyright = "2026, the tetlap developers"
release = version = tetlap.__version__

extensions = ["sphinx.ext.autodoc", "sphinx.ext.napoleon", "sphinx.ext.intersphinx",
              "myst_parser", "sphinx_gallery.gen_gallery"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "gallery/*.ipynb", "gallery/*.py", "gallery/*.zip",
                    "experiments/**"]
autodoc_member_order = "bysource"
autodoc_typehints = "none"
# The optional frameworks need not be installed to document their adapters.
autodoc_mock_imports = ["torch"]
napoleon_numpy_docstring = True
napoleon_google_docstring = False
napoleon_use_rtype = False
myst_heading_anchors = 3
# A link that names no page or heading is an error; the included pages start at "##".
suppress_warnings = ["myst.header"]
intersphinx_mapping: dict = {}

html_theme = "pydata_sphinx_theme"
html_title = f"tetlap {release}"
html_static_path: list[str] = []
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": [],
}
html_sidebars = {"index": []}

# The gallery: every examples/plot_*.py runs on each build, on small meshes (the whole
# gallery in about ten seconds on 2 cores); an example that raises fails the build.
sphinx_gallery_conf = {
    "examples_dirs": "../examples",
    "gallery_dirs": "gallery",
    "filename_pattern": r"/plot_",
    "within_subsection_order": "FileNameSortKey",
    "image_scrapers": ("matplotlib",),
    "reset_modules": ("matplotlib",),
    "abort_on_example_error": True,
    "download_all_examples": False,
    "remove_config_comments": True,
    "doc_module": ("tetlap",),
    "backreferences_dir": "api/backreferences",
    "show_memory": False,
    "min_reported_time": 1,
}
os.environ.setdefault("MPLBACKEND", "Agg")


class CommandHelp(Directive):
    """``.. tetlap-help:: COMMAND`` (or ``tetlap``): the command's ``--help``, as printed,
    so the documentation of the CLI cannot drift from its parser."""

    required_arguments = 1

    def run(self):
        from tetlap import cli

        parser = cli.parser()
        name = self.arguments[0]
        if name != "tetlap":
            (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
            parser = sub.choices[name]
        text = parser.format_help()
        return [nodes.literal_block(text, text)]


def data_comment(app, what, name, obj, options, lines):
    """A constant documented where a user types it (``tetlap.solve.RESIDUAL_TOL``) but
    defined, with its ``#:`` comment, in a private module (``tetlap.solve._checks``): its
    comment, found in the module that defines it, instead of the docstring of its type
    (``float``, ``tuple``) that autodoc falls back to. A constant with neither is a
    warning, so an undocumented constant fails the build."""
    doc = type(obj).__doc__
    if what != "data" or not doc or (lines and lines[0].strip() != doc.strip().splitlines()[0]):
        return
    short = name.rsplit(".", 1)[1]
    for module_name in sorted(sys.modules):
        module = sys.modules[module_name]
        if not module_name.startswith("tetlap") or getattr(module, short, None) is not obj:
            continue
        try:
            comments = ModuleAnalyzer.for_module(module_name).find_attr_docs()
        except PycodeError:
            continue
        if ("", short) in comments:
            lines[:] = list(comments[("", short)])
            return
    lines[:] = []
    if name not in DOCUMENTED_IN_PAGE:
        logger.warning(f"{name}: no #: comment documents this constant", type="tetlap")


#: Constants of the compiled core (no source to read a comment from), described in the
#: reference's own text instead.
DOCUMENTED_IN_PAGE = {"tetlap.MAX_THREADS"}


def setup(app):
    app.add_directive("tetlap-help", CommandHelp)
    app.connect("autodoc-process-docstring", data_comment)
