"""Check a built HTML site for broken internal links: every relative ``href`` and ``src``
must name a file of the site, and every ``#anchor`` an id of its page.

Run:  python docs/check_links.py docs/_build/html   (exit code 1 and one line per broken
link if any; external links, which an offline build cannot follow, are not checked)
"""

from __future__ import annotations

import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit


class _Page(HTMLParser):
    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.links: list[str] = []
        self.ids: set[str] = set()

    def handle_starttag(self, tag, attrs):
        for name, value in attrs:
            if name == "id" and value:
                self.ids.add(value)
            elif name in ("href", "src") and value:
                self.links.append(value)


def _parse(path: Path) -> _Page:
    page = _Page()
    page.feed(path.read_text(encoding="utf-8", errors="replace"))
    return page


def broken_links(site: Path) -> list[str]:
    """One line per broken internal link of the site at ``site``."""
    site = site.resolve()
    # _static holds the theme's templates, not pages
    pages = {p: _parse(p) for p in site.rglob("*.html") if "_static" not in p.parts}
    broken = []
    for path, page in pages.items():
        for link in page.links:
            parts = urlsplit(link)
            if parts.scheme or parts.netloc or link.startswith(("mailto:", "data:")):
                continue  # external, or inline data
            target = (path.parent / unquote(parts.path)).resolve() if parts.path else path
            if target.is_dir():
                target = target / "index.html"
            if not target.is_relative_to(site):
                # it may exist in the checkout, not where the site is published
                broken.append(f"{path.relative_to(site)}: {link} (outside the site)")
            elif not target.exists():
                broken.append(f"{path.relative_to(site)}: {link} (no such file)")
            elif parts.fragment and target.suffix == ".html":
                ids = pages[target].ids if target in pages else _parse(target).ids
                if unquote(parts.fragment) not in ids:
                    broken.append(f"{path.relative_to(site)}: {link} (no such anchor)")
    return broken


def main(argv: list[str]) -> int:
    site = Path(argv[0] if argv else "docs/_build/html")
    if not (site / "index.html").exists():
        print(f"check_links: {site} holds no built site (index.html)", file=sys.stderr)
        return 2
    broken = broken_links(site)
    for line in broken:
        print(line)
    n = sum(1 for p in site.rglob("*.html") if "_static" not in p.parts)
    print(f"check_links: {n} pages, {len(broken)} broken internal links", file=sys.stderr)
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
