# Sphinx configuration of the Python API reference (make docs -> build/doc/python/index.html).
import os
import sys

sys.path.insert(0, os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", "python")))
project = "tubes"
extensions = ["sphinx.ext.autodoc"]
autodoc_default_options = {"members": True, "undoc-members": True}
autodoc_member_order = "bysource"
html_theme = "alabaster"
exclude_patterns = []


def _plain(app, what, name, obj, options, lines):
    """The package's docstrings are plain text (|x| is an absolute value, not an RST substitution):
    shown as written, in a literal block."""
    if lines:
        lines[:] = ["::", ""] + ["    " + ln for ln in lines] + [""]


def setup(app):
    app.connect("autodoc-process-docstring", _plain)
