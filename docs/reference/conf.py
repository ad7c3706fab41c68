# Sphinx configuration of the pardel reference: the Python package pardel (autodoc) with a link to
# the C++ headers' Doxygen pages. Built by tools/docs/build.sh, which puts the build folder's
# package on PYTHONPATH (pardel imports its compiled core, so the module must be built first).
import pardel

project = "pardel"
version = release = pardel.__version__
extensions = ["sphinx.ext.autodoc"]
# Members in the order of the source, and the type hints
# shown in the signatures (not repeated in the descriptions).
autodoc_member_order = "bysource"
autodoc_typehints = "signature"
autodoc_default_options = {"members": True, "show-inheritance": True}
# `text` in the docstrings names code (a command, a key, an argument): shown as literal text.
default_role = "literal"
# Not nitpicky: the type hints name NumPy's, SymPy's and typing's classes, which this reference
# does not document (no intersphinx: the build reads nothing from the network).
nitpicky = False
html_theme = "alabaster"
# The docstrings' quotes and dashes are code ("--set", "converged"): kept as written.
smartquotes = False
