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

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "_ext"))

# Under rosdoc2 its generated pages sit beside this file (sphinx-apidoc's modules.rst, standards.rst):
# index.rst then links them (`.. only:: rosdoc2`), and they are in no toctree of ours.
if os.path.isfile(os.path.join(HERE, "modules.rst")) and os.path.isfile(os.path.join(HERE, "standards.rst")):
    tags.add("rosdoc2")  # noqa: F821 (Sphinx gives conf.py its tags)
    suppress_warnings = ["toc.not_included"]

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

# `make docs` builds nitpicky (-n): every reference must resolve. Not set here, so that rosdoc2's build of the
# generated Python API does not report every numpy type its docstrings name.

html_theme = "alabaster"  # rosdoc2 uses its own
html_title = "pmv_ros"
html_show_sourcelink = False
