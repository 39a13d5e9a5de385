"""sphinx-gallery helpers: show the PNG files an example writes with sins-sim's own plot functions.

sins-sim's plot functions write a figure file and close the figure (the same call the command line
makes), so matplotlib's scraper sees nothing. :class:`PngFolderScraper` picks up every PNG that a
code block wrote into the folder the example names ``out`` (a :class:`pathlib.Path`), in the
order written, and hands it to sphinx-gallery like a figure.
"""

from __future__ import annotations

import shutil
from pathlib import Path


class PngFolderScraper:
    """Scraper for the figures an example writes into its ``out`` folder (sphinx-gallery API)."""

    def __init__(self):
        self.seen: set[Path] = set()

    def __repr__(self):  # sphinx-gallery keys its cache on the repr
        return "PngFolderScraper"

    def __call__(self, block, block_vars, gallery_conf):
        from sphinx_gallery.scrapers import figure_rst

        out = block_vars["example_globals"].get("out")
        if not isinstance(out, Path) or not out.is_dir():
            return ""
        new = sorted((p for p in out.rglob("*.png") if p.resolve() not in self.seen), key=lambda p: p.stat().st_mtime)
        written = []
        for png, target in zip(new, block_vars["image_path_iterator"]):
            self.seen.add(png.resolve())
            shutil.copyfile(png, target)
            written.append(target)
        return figure_rst(written, gallery_conf["src_dir"])


def reset_matplotlib(gallery_conf, fname):
    """Close every figure between examples (sphinx-gallery ``reset_modules``)."""
    import matplotlib.pyplot as plt

    plt.close("all")
