"""Sphinx configuration of the sins-sim documentation.

Build: ``python -m sphinx -W --keep-going -b html docs docs/_build/html`` (or ``make docs``).
The examples under ``docs/examples`` run at every build (sphinx-gallery); a failing example
fails the build. Generated folders (``docs/gallery``, ``docs/getting-started/tutorial``,
``docs/reference/api``, ``docs/_build``) are not part of the source tree (.gitignore).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))
os.environ.setdefault("MPLBACKEND", "Agg")

import sins_sim  # noqa: E402

project = "sins-sim"
author = "the sins-sim developers"
copyright = "the sins-sim developers, MIT licence"
version = release = sins_sim.__version__

extensions = [
    "myst_parser",
    "numpydoc",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx_gallery.gen_gallery",
    "sphinxarg.ext",
    "sphinxcontrib.bibtex",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "examples/**", "**/*.ipynb"]

# --- MyST (Markdown pages) ---------------------------------------------------------------------
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

# --- API reference: autosummary + numpydoc ----------------------------------------------------------
templates_path = ["_templates"]
autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {"members": False}
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()

# --- references ------------------------------------------------------------------------------------
bibtex_bibfiles = ["references.bib"]
bibtex_default_style = "plain"
bibtex_reference_style = "label"  # numbered: the paper and the spec have no author to cite by

# --- gallery: every example runs at every build ----------------------------------------------------
sys.path.insert(0, str(DOCS))
from _gallery import PngFolderScraper, reset_matplotlib  # noqa: E402

sphinx_gallery_conf = {
    "examples_dirs": ["examples/getting_started", "examples/figures"],
    "gallery_dirs": ["getting-started/tutorial", "gallery"],
    "filename_pattern": r"/plot_",  # every plot_*.py runs; a file without the prefix is shown only
    "within_subsection_order": "FileNameSortKey",
    "image_scrapers": ("matplotlib", PngFolderScraper()),
    "reset_modules": (reset_matplotlib, "matplotlib"),
    "abort_on_example_error": True,  # a failing example stops the build ...
    "only_warn_on_example_error": False,  # ... and is an error, never a warning
    "download_all_examples": False,
    "remove_config_comments": True,
    "show_memory": False,
    "plot_gallery": "True",
    "write_computation_times": True,
    "capture_repr": ("_repr_html_", "__repr__"),
}

# --- HTML ----------------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"sins-sim {release}"
html_static_path = ["_static"]
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
}
html_show_sourcelink = False
suppress_warnings = ["config.cache"]  # sphinx-gallery's configuration holds functions; it is rebuilt every time
