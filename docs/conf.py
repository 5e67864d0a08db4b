"""Sphinx configuration of the mfcontrol documentation.

Built with ``pip install ".[docs]" && sphinx-build -W -b html docs docs/_build/html``.
Every build runs the example gallery (examples/*.py) and ``mfcontrol reproduce``, so the
figures on the site are this checkout's; the API reference lists ``mfcontrol.__all__``.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import mfcontrol

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
GENERATED = DOCS / "_generated"

project = "mfcontrol"
author = "the mfcontrol developers"
copyright = "2026, the mfcontrol developers"  # noqa: A001 (Sphinx's name)
release = mfcontrol.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.intersphinx",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "_generated", "_templates", "reports/benchmark/**",
                    "auto_examples/*.ipynb", "auto_examples/*.py", "auto_examples/*.zip",
                    "auto_examples/*.json"]
templates_path = ["_templates"]
myst_enable_extensions = ["dollarmath"]
myst_heading_anchors = 3

# every page offline: MathJax is the one script a page would fetch; the theme ships the rest
html_theme = "pydata_sphinx_theme"
html_title = f"mfcontrol {release}"
html_theme_options = {"navigation_with_keys": False, "show_toc_level": 2}
html_static_path: list[str] = []

autosummary_generate = True
autodoc_default_options = {"members": True, "member-order": "bysource"}
autodoc_typehints = "signature"  # in the signature line; the Parameters say the rest
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
intersphinx_mapping: dict[str, tuple[str, None]] = {}  # offline build: no inventories


# --- the API reference: one autosummary table per defining module, from __all__ -------

SECTIONS = {  # the order and the words of the reference's sections
    ".api.model.controllers": "Live controllers",
    ".api.model.plants": "Plants",
    ".api.model.elements": "Loop elements: sensor, actuator, disturbance",
    ".api.model.schedule": "Scheduled changes of a plant's parameters",
    ".api.run.loop": "Simulating a loop",
    ".api.run.sweep": "Sweeping a loop",
    ".api.run.simulate": "Simulating a configuration",
    ".experiments.analyze": "Linear analysis of a case's loop, or a controller's on a plant",
    ".analysis.filters": "Linear analysis: a law as its linear filter",
    ".analysis.loop": "Linear analysis: poles and margins of the loop",
    ".analysis.alpha": "The gain alpha: from data, from a plant, its stable range",
    ".api.results.result": "Results",
    ".experiments.cases": "Built-in cases",
    ".config.resolve": "Configuration",
    ".experiments.tune": "Tuning",
    ".experiments.compare": "Comparing controllers",
    ".experiments.statistics": "Statistics of a comparison: paired differences, restarts",
    ".analysis.tuning_rules": "Rule-tuned PIDs: FOPDT models, SIMC and AMIGO",
    ".cexport": "C export",
    ".errors": "Errors",
}


def _write_api_page() -> None:
    exports = mfcontrol._EXPORTS
    missing = set(exports) ^ set(SECTIONS)
    if missing:
        raise RuntimeError(f"docs/conf.py SECTIONS and mfcontrol._EXPORTS differ: {missing}")
    lines = ["API reference", "=============", "",
             "Every public name of ``mfcontrol`` (``mfcontrol.__all__``), by what it is for.",
             "", ".. currentmodule:: mfcontrol", ""]
    for module, title in SECTIONS.items():
        lines += [title, "-" * len(title), "", ".. autosummary::", "   :toctree: generated",
                  "   :nosignatures:", ""]
        lines += [f"   {name}" for name in exports[module]]
        lines.append("")
    page = DOCS / "api.rst"
    text = "\n".join(lines)
    if not page.exists() or page.read_text() != text:
        page.write_text(text)


# --- the reproduction report, as `mfcontrol reproduce` writes it ------------------------

def _write_reproduction() -> None:
    """Run ``mfcontrol reproduce`` at every build (about 30 s): a report kept from an
    earlier build would describe the library as it was then."""
    out = GENERATED / "reproduction"
    shutil.rmtree(out, ignore_errors=True)
    subprocess.run([sys.executable, "-m", "mfcontrol.cli", "reproduce", "--out", str(out)],
                   check=True, stdout=subprocess.DEVNULL)


def _drop_stale_pages() -> None:
    """Pages an earlier build generated for what no longer exists (an API name removed,
    an example deleted) would fail the build as documents in no table of contents."""
    shutil.rmtree(DOCS / "generated", ignore_errors=True)
    gallery = DOCS / "auto_examples"
    for page in gallery.glob("*.rst"):
        if page.stem not in ("index", "sg_execution_times") and not (
                ROOT / "examples" / f"{page.stem}.py").exists():
            page.unlink()


# --- the gallery: each example writes its figure where the scraper finds it -------------

sys.path.insert(0, str(DOCS))

sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r".*\.py",  # every example runs
    "reset_argv": "gallery_hooks.example_argv",
    "image_scrapers": ("gallery_hooks.figure_scraper",),
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "abort_on_example_error": True,
    "show_memory": False,
    "plot_gallery": "True",
    # every build runs every example: the figures are this checkout's library's, not those
    # of the build that last saw the script change
    "run_stale_examples": True,
}


def _write_disagreements() -> None:
    from mfcontrol.experiments.report import disagreements_markdown

    (GENERATED / "disagreements.md").write_text(disagreements_markdown() + "\n")


def setup(app):
    GENERATED.mkdir(exist_ok=True)
    _drop_stale_pages()
    _write_api_page()
    _write_disagreements()
    _write_reproduction()
