"""Sphinx configuration of tetlap's API reference (built by .ci/run with warnings as errors:
python -m sphinx -W -b html docs/api target/docs)."""

import tetlap

project = "tetlap"
author = "The tetlap developers"
copyright = "2026, the tetlap developers"
release = version = tetlap.__version__

extensions = ["sphinx.ext.autodoc", "sphinx.ext.napoleon", "sphinx.ext.intersphinx",
              "myst_parser"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build"]
autodoc_member_order = "bysource"
autodoc_typehints = "none"
# the optional frameworks need not be installed to document their adapters
autodoc_mock_imports = ["jax", "torch"]
napoleon_numpy_docstring = True
napoleon_google_docstring = False
napoleon_use_rtype = False
nitpicky = False
myst_heading_anchors = 3
suppress_warnings = ["myst.header", "myst.xref_missing"]
html_theme = "alabaster"
html_static_path: list[str] = []
intersphinx_mapping: dict = {}
