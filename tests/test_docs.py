"""The README and the user guide state what the code does: the guide's option table,
the README's quick-start commands and links, the examples of both."""

import re
from pathlib import Path

import pytest

from mfcontrol.config.options import options_markdown

ROOT = Path(__file__).resolve().parents[1]


def test_guide_option_table_is_the_schema():
    page = ROOT / "docs" / "guide" / "options.md"
    assert options_markdown() in page.read_text(encoding="utf-8")


def test_readme_quick_start_commands():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert 'pip install . && mfcontrol reproduce --out results' in text
    assert 'pip install ".[test]" && pytest' in text
    assert 'pip install ".[test]" && pytest' in (ROOT / ".ci" / "run").read_text()


def test_readme_docs_command_is_what_ci_runs():
    """The README's one command builds the site with warnings as errors, and CI runs it."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert 'pip install ".[docs]" && sphinx-build -W -b html docs docs/_build/html' in text
    ci = (ROOT / ".ci" / "run").read_text()
    assert 'pip install ".[docs]"' in ci
    assert "sphinx-build -W -b html docs docs/_build/html" in ci
    assert "python docs/check_links.py docs/_build/html" in ci


def test_guide_pages_are_their_own_text_and_all_listed():
    """The guide's pages hold their text (none includes the README, which is short and
    links to them), and the guide's table of contents lists every page."""
    guide = ROOT / "docs" / "guide"
    pages = sorted(p.stem for p in guide.glob("*.md") if p.stem != "index")
    assert pages
    for page in [*guide.glob("*.md"), ROOT / "docs" / "index.md"]:
        assert not re.search(r"\{include\}.*README", page.read_text(encoding="utf-8")), page
    toctree = (guide / "index.md").read_text(encoding="utf-8").split("{toctree}")[1]
    assert pages == sorted(line.strip() for line in toctree.split("```")[0].splitlines()
                           if line.strip() and not line.startswith(":")), pages


def test_readme_links_point_to_files_that_exist():
    """The README's relative links (the guide's pages, images) work on GitHub: each names
    a file of the repository."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    links = [link.split("#")[0] for link in re.findall(r"\]\(([^)\s]+)\)", text)
             if "://" not in link and not link.startswith("#")]
    assert any(link.startswith("docs/guide/") for link in links)
    missing = [link for link in links if not (ROOT / link).exists()]
    assert not missing, missing


@pytest.mark.parametrize("name", ["README.md", "docs/guide/own-plant.md"])
def test_plant_example_runs(name, tmp_path, monkeypatch):
    text = (ROOT / name).read_text(encoding="utf-8")
    blocks = text.split("```python\n")[1:]
    code = next(b.split("```")[0] for b in blocks if "plant = ODE(" in b)
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile(code, name, "exec"), namespace)  # noqa: S102
    assert namespace["res"].metrics["settled"] and namespace["res"].engine == "compiled"
    assert (tmp_path / "motor.png").exists()
    table = namespace["sweep"].to_pandas()
    assert len(table) == 12 and table["settled"].any()


def test_link_checker_finds_broken_files_and_anchors(tmp_path):
    import runpy

    check = runpy.run_path(str(ROOT / "docs" / "check_links.py"))
    (tmp_path / "sub").mkdir()
    (tmp_path / "index.html").write_text(
        '<a href="sub/page.html#here">ok</a> <a href="sub/page.html#gone">anchor</a> '
        '<img src="missing.png"> <a href="https://example.org/x">external</a> '
        '<a href="#top" id="top">self</a> <a href="../outside.html">up</a>')
    (tmp_path.parent / "outside.html").write_text("exists, but not in the site")
    (tmp_path / "sub" / "page.html").write_text('<h1 id="here">x</h1><a href="../index.html">')
    broken = check["broken_links"](tmp_path)
    assert sorted(broken) == ["index.html: ../outside.html (outside the site)",
                              "index.html: missing.png (no such file)",
                              "index.html: sub/page.html#gone (no such anchor)"]
    assert check["main"]([str(tmp_path)]) == 1
    (tmp_path / "index.html").write_text('<a href="sub/page.html#here">ok</a>')
    assert check["main"]([str(tmp_path)]) == 0
