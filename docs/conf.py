"""Sphinx configuration of rbenv's documentation site (``python -m sphinx -W docs docs/_build``).

The pages are the Markdown files of docs/ (MyST), the env and scene pages that
``_ext/rbenv_pages.py`` generates from the registry and the scene files at build time, the API
reference from the docstrings, and the tutorials, which MyST-NB executes while the site builds.
"""

from __future__ import annotations

import sys
from pathlib import Path

import rbenv

sys.path.insert(0, str(Path(__file__).parent / "_ext"))

project = "rbenv"
author = "the rbenv developers"
copyright = "2025-2026, the rbenv developers"
release = rbenv.__version__
version = ".".join(release.split(".")[:2])

extensions = [
    "myst_nb",  # MyST Markdown and executed text notebooks (brings myst_parser)
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.viewcode",
    "sphinx_copybutton",
    "rbenv_pages",
]

source_suffix = {".md": "myst-nb", ".rst": "restructuredtext"}
exclude_patterns = [
    "_build", "Thumbs.db", ".DS_Store",
    "innocube/innocube_effects.md",  # a benchmark's own table, linked from the InnoCube page
]
myst_enable_extensions = ["colon_fence", "dollarmath", "deflist"]
myst_heading_anchors = 4
suppress_warnings = ["myst.header"]  # pages that start below level 1 (a README section)

# Tutorials run when the site is built; a cell that raises fails the build.
nb_execution_mode = "force"
nb_execution_timeout = 300
nb_execution_raise_on_error = True
nb_execution_show_tb = True

autodoc_default_options = {"members": True, "show-inheritance": False}
autodoc_member_order = "bysource"
autodoc_typehints = "none"  # the docstrings carry shapes and units
autodoc_mock_imports: list[str] = []

html_theme = "furo"
html_title = f"rbenv {release}"
html_static_path = ["_static"]
html_favicon = "_static/favicon.png"
html_show_sourcelink = False
