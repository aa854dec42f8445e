"""Sphinx configuration of robrst's documentation (``sphinx-build -W -b html docs docs/_build/html``)."""

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))
sys.path.insert(0, str(HERE.parent))            # the checkout's robrst, as the tests import it

import robrst                                    # noqa: E402

project = "robrst"
author = "robrst contributors"
copyright = "2026, robrst contributors"
release = version = robrst.__version__

extensions = [
    "myst_parser",
    "numpydoc",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "robrst_docs",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "**/.ipynb_checkpoints"]

myst_enable_extensions = ["colon_fence", "dollarmath"]
smartquotes = False                          # defaults and keys render as typed
myst_heading_anchors = 3

autosummary_generate = True
autosummary_ignore_module_all = False        # a module's members are its __all__
autodoc_default_options = {"members": True, "show-inheritance": False}
autodoc_typehints = "none"                   # numpydoc's Parameters carry the types
autodoc_member_order = "bysource"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

html_theme = "pydata_sphinx_theme"
html_title = "robrst"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
}
html_static_path = []
