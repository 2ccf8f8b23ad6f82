"""The documentation site (Sphinx with MyST Markdown): ``make docs`` builds it into docs/_build/html, offline, every
warning an error. The pages are Markdown files beside this one; the CLI and configuration references are generated
from the code (``python -m vpr_smr.pipeline.reference --write``), the Python API's from its docstrings (autodoc)."""

import importlib.metadata
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent / "_ext"))

project = "vpr-smr"
author = "The vpr-smr developers"
release = importlib.metadata.version("vpr-smr")
copyright = "the vpr-smr developers (code MIT; Nordland frames CC BY 3.0 NRK)"

extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.napoleon", "mathml"]
exclude_patterns = ["_build"]

# Markdown: $...$ and $$...$$ maths, and GitHub's heading anchors so that `page.md#a-heading` links work both here
# and on GitHub.
myst_enable_extensions = ["dollarmath"]
myst_heading_anchors = 4
# Text as written: `--option` in prose stays two hyphens (Sphinx would make it a dash), quotes stay straight.
smartquotes = False

# Every reference must resolve (nitpicky), and the maths is MathML written at build time (_ext/mathml.py): the
# pages load nothing from outside (no MathJax from a CDN, no web fonts: Furo uses the system's).
nitpicky = True
html_math_renderer = "mathml"
html_theme = "furo"
html_title = f"vpr-smr {release}"
html_show_sourcelink = False
html_copy_source = False

autodoc_typehints = "description"
autodoc_member_order = "bysource"
autodoc_default_options = {"members": True}
napoleon_google_docstring = True
napoleon_numpy_docstring = False

# The Python API's signatures name NumPy's, the standard library's and pathlib's types, which no page here documents.
nitpick_ignore_regex = [("py:class", r"(numpy|collections\.abc|pathlib)\..*")]
