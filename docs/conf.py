"""Sphinx configuration of the gyrotest reference manual.

Build (from the repository root; ``pip install '.[docs]'``)::

    sphinx-build -W -b html docs docs/_build/html

Extensions and why:

* ``sphinx.ext.autodoc`` -- the API reference comes from the docstrings themselves;
* ``numpydoc`` -- the docstrings are written in numpydoc form (the format of numpy, scipy,
  pandas and pvlib, which our users read every day); numpydoc is that format's reference
  renderer, and its validator (``numpydoc_validation_checks``) fails the build (``-W``) when a
  public function's parameters and docstring disagree. Napoleon, Sphinx's bundled
  alternative, renders the same sections but checks nothing;
* ``myst_nb`` -- pages and notebooks in MyST Markdown: the worked notebooks are plain text
  (``docs/notebooks/*.md``, no outputs in git, reviewable diffs) and are executed on every
  build, so their numbers never go stale; no pandoc binary is needed (nbsphinx needs one);
* ``sphinx.ext.mathjax`` -- the equations of the docstrings.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
# the notebooks and doctest-style examples use repository-relative paths (sample_data/ and
# ../shared/reference/data); their kernels start in the repository root
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import gyrotest  # noqa: E402

project = "gyrotest"
author = "gyrotest developers"
copyright = "gyrotest developers"  # noqa: A001
release = version = gyrotest.__version__

extensions = [
    "myst_nb",
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "numpydoc",
]

source_suffix = {".md": "myst-nb", ".rst": "restructuredtext"}
exclude_patterns = ["_build", "spec-page1.png", "**/.ipynb_checkpoints", "jupyter_execute"]
root_doc = "index"
html_theme = "alabaster"
html_title = f"gyrotest {release}"
html_static_path: list[str] = []

# --- MyST / notebooks
myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 3
nb_execution_mode = "force"  # every build runs every notebook: the numbers never go stale
nb_execution_timeout = 600
nb_execution_raise_on_error = True
nb_execution_in_temp = False
nb_execution_allow_errors = False
nb_merge_streams = True

# --- autodoc / numpydoc
autodoc_member_order = "bysource"
autodoc_typehints = "none"  # the numpydoc Parameters section states types and units
numpydoc_show_class_members = False
numpydoc_xref_param_type = False
numpydoc_validation_checks = {"PR01", "PR02", "PR03", "PR10", "RT02"}
# results are made by the functions, never by users: their constructors (core, **meta) are
# not documented; the error subclasses take GyrotestError's documented parameters
numpydoc_validation_exclude = {r"\._", r"__init__$", r"\.to_json$",
                               r"^gyrotest\.[A-Za-z]*(Result|Report|Simulation|Fit|Diagnosis)$",
                               r"^gyrotest\.api\.results\.Result$",
                               r"^gyrotest\.(InputError|OptionError|AnalysisError)$"}
nitpicky = False
suppress_warnings = ["myst.header"]
