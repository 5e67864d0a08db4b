"""How sphinx-gallery runs mfcontrol's examples: each example saves its own figure (as
it does from the command line), given a path on its command line; the scraper puts that
PNG on the example's page.

sphinx-gallery imports these by name ("gallery_hooks.example_argv"), so that its
configuration pickles (conf.py puts this folder on sys.path).
"""

from __future__ import annotations

import shutil
from pathlib import Path

FIGURES = Path(__file__).resolve().parent / "_generated" / "gallery-figures"


def _figure_of(src_file: str) -> Path:
    return FIGURES / f"{Path(src_file).stem}.png"


def example_argv(gallery_conf: dict, script_vars: dict) -> list[str]:
    """The arguments after the script's name: where its figure goes."""
    FIGURES.mkdir(parents=True, exist_ok=True)
    return [str(_figure_of(script_vars["src_file"]))]


def figure_scraper(block, block_vars: dict, gallery_conf: dict) -> str:
    """Move the PNG the example wrote to the gallery's image path; its rST."""
    from sphinx_gallery.scrapers import figure_rst

    written = _figure_of(block_vars["src_file"])
    if not written.exists():
        return ""
    target = next(block_vars["image_path_iterator"])
    shutil.move(written, target)
    return figure_rst([target], gallery_conf["src_dir"])
