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

# Nitpicky mode (make docs: -n -W) holds every cross-reference to a target.  Nothing is fetched
# from the network, so types of other libraries (numpy, pandas, the standard library, pydantic's
# field constraints) have no target to link and are left as text; the project's own must resolve.
nitpick_ignore_regex = [
    ("py:.*", r"(numpy|np|pandas|pd|scipy|pathlib|os|collections\.abc|typing|types|annotated_types|"
              r"pydantic)(\..*)?"),
    ("py:.*", r"(Path|Callable|Mapping|Sequence|BaseModel|Field|FieldInfo|AllowInfNan|Ge|Gt|Le|Lt|MinLen|"
              r"MaxLen)"),
    # (the scenario's field types and unions of its tables)
    ("py:.*", r"(Positive|NonNegative|Real|Floor|Mass|MAX_[A-Z_]+|Absorber|Load|Distribution|Envelope)"),
    ("py:.*", r".*=.*|Annotated\[.*|[-+0-9.e]+"),  # (pieces of pydantic's Field(...) metadata)
]

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
