# Sphinx configuration of the pmv_ros documentation.
#
# `make docs` builds it (sphinx-build -W --keep-going -n -E docs docs/_build/html). rosdoc2, the
# ROS 2 documentation tool, builds the same project: package.xml exports rosdoc2.yaml, which names
# this folder as the Sphinx source (rosdoc2 looks in doc/ by default). rosdoc2 copies this folder
# into its own build directory, runs this file from its wrapping conf.py and adds what it generates
# itself: the package page from package.xml, the Python API (sphinx-apidoc), the standard documents
# (README.md, CHANGELOG.rst, LICENSE) and its theme, autodoc, intersphinx and myst_parser. So nothing
# here may depend on where this file lies: `_ext` is found beside the wrapping conf.py too.
#
# The parameter reference is generated at build time from the nodes' ParamSpec tables by
# _ext/pmv_parameters.py, with a doc line per parameter from parameter_notes.yaml.
#
# docs/incoming/ is where work on a feature drops its user-facing text (parameters, topics,
# /diagnostics keys, commands, limitations); it is not built. The lead folds each file into the
# pages here (docs/README.md says which page takes what) and deletes it.

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "_ext"))

project = "pmv_ros"
author = "pmv_ros maintainers"
copyright = "pmv_ros maintainers"

extensions = ["myst_parser", "pmv_parameters"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "incoming", "README.md", "Thumbs.db", ".DS_Store"]

# Markdown: definition lists and `(label)=` targets; heading anchors to level 3 for links like
# robustness.md#a-hostile-clock.
myst_enable_extensions = ["deflist", "colon_fence"]
myst_heading_anchors = 3

# Every reference must resolve. Message types and ROS tools are named in code spans, not cross-references,
# so nothing external is looked up.
nitpicky = True

html_theme = "alabaster"
html_theme_options = {"page_width": "1180px", "sidebar_width": "240px"}
html_title = "pmv_ros"
html_show_sourcelink = False
