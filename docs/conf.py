"""Sphinx configuration of the volerr_pin documentation site.

Build it from the repository's root (``pip install -e ".[docs]"`` first)::

    sphinx-build -W --keep-going -b html docs docs/_build/html

The pages are the Markdown files of ``docs/`` (read by myst-parser, so they stay readable on
a forge too); the API reference is generated from the numpydoc docstrings (autodoc +
autosummary + numpydoc); the pictures of the guide are written during the build by the
product's own PNG writers (``_ext/figures.py``); the gallery runs every example and shows
the pictures it writes (sphinx-gallery, ``_ext/gallery.py``).
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

project = "volerr_pin"
author = "volerr_pin developers"
copyright = "volerr_pin developers, BSD-3-Clause"

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "numpydoc",
    "docstrings",
    "apipages",
    "figures",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}  # the API pages are .rst
root_doc = "index"
exclude_patterns = ["_build", "_generated", "Thumbs.db", ".DS_Store"]

# Markdown: GitHub-style anchors for the links between pages (``reports.md#volerr-gear---json``)
myst_heading_anchors = 4
myst_enable_extensions = ["colon_fence"]
# reports.md shows abridged JSON (with "..."): it is not meant to lex as JSON, so a block
# that does not is shown plain instead of failing the build
suppress_warnings = ["misc.highlighting_failure"]
# the pages quote transcripts in ```text blocks and commands in ```sh blocks
highlight_language = "none"

# API reference: one page per module (_ext/apipages.py), generated from the docstrings
autodoc_default_options = {"members": True}
autodoc_typehints = "none"          # the numpydoc sections carry types, shapes and units
autodoc_member_order = "bysource"
numpydoc_show_class_members = False  # autodoc documents the members in full
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# pydata-sphinx-theme: the look and navigation of NumPy, SciPy and pandas, which our readers
# already know (sections in the top bar, the section's pages on the left, the page's
# headings on the right, search, light and dark); its content column is widened (_static)
# so that the reports' wide tables and the multi-panel pictures keep their size
html_theme = "pydata_sphinx_theme"
html_title = "volerr_pin"
html_static_path = ["_static"]
html_css_files = ["wide.css"]
html_theme_options = {
    "navbar_align": "left",
    "show_toc_level": 2,
    "navigation_depth": 2,
    "show_prev_next": True,
    "header_links_before_dropdown": 6,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": [],
}
html_sidebars = {"**": ["sidebar-nav-bs"]}
html_show_sourcelink = False

# The gallery of examples (sphinx-gallery): every example runs once, in a folder of its own
# (_ext/gallery.py), and its pictures and output are shown above its code. The two on other
# groups' data are shown without running; the sample-data writer is left out.
sphinx_gallery_conf = {
    "examples_dirs": "../examples",
    "gallery_dirs": "gallery",
    "filename_pattern": r"/(?!.*_real_data\.py$)",
    "ignore_pattern": r"make_sample_data\.py$",
    "within_subsection_order": "FileNameSortKey",
    "image_scrapers": ("gallery.pictures",),
    "reset_argv": "gallery.argv",
    "abort_on_example_error": True,
    "download_all_examples": False,
    "write_computation_times": False,
    "show_memory": False,
    "remove_config_comments": True,
}
