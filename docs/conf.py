"""Sphinx configuration of the vines_stoch documentation (``make docs``).

Sphinx with myst-parser (pages in Markdown), autodoc (the API from docstrings), sphinx-gallery
(the examples in ``examples/``, run at every build) and the furo theme. The scenario and
command-line references are written from the code before each build (``_ext/vines_reference.py``).
Nothing is fetched from the network: no intersphinx.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))
os.environ.setdefault("MPLBACKEND", "Agg")

import vines_stoch  # noqa: E402

project = "vines_stoch"
author = "the vines_stoch authors"
copyright = "the vines_stoch authors, MIT licence"
release = vines_stoch.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "sphinx_gallery.gen_gallery",
    "vines_reference",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
exclude_patterns = ["_build"]
myst_enable_extensions = ["dollarmath", "amsmath"]
myst_heading_anchors = 3

autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"members": True, "undoc-members": False}

sphinx_gallery_conf = {
    "examples_dirs": str(HERE.parent / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
}

html_theme = "furo"
html_title = f"vines_stoch {release}"
html_static_path = ["_static"]
