"""Sphinx configuration: the docs/*.md pages (MyST) and an API reference from the docstrings.

Built by ``make docs`` with warnings as errors (``-W``)."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

project = "armlab"
author = "the armlab developers"
copyright = "the armlab developers, MIT licence"

extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.napoleon"]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build"]
myst_heading_anchors = 3
# The pages link to source files and to one another by relative path (readable on GitHub too).
suppress_warnings = ["myst.xref_missing"]

autodoc_member_order = "bysource"
autodoc_typehints = "none"          # the docstrings give shapes and units; signatures stay short
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": True}
napoleon_google_docstring = False
napoleon_numpy_docstring = True

html_theme = "alabaster"
html_title = "armlab"
napoleon_use_ivar = True            # "Attributes" as fields: the dataclass fields are documented once
# Types in the docstrings are shapes and units ("(n,)", "[m | rad]"), not classes to link to.
suppress_warnings += ["ref.python"]


def _escape_bars(app, what, name, obj, options, lines):
    """Absolute values |x| in docstrings are text, not reStructuredText substitutions: escape
    every bar outside ``literal`` spans."""
    for index, line in enumerate(lines):
        parts = line.split("``")
        lines[index] = "``".join(part.replace("|", r"\|") if k % 2 == 0 else part
                                 for k, part in enumerate(parts))


def setup(app):
    app.connect("autodoc-process-docstring", _escape_bars)
