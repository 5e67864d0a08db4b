"""The README states what the code does: its option table and quick-start commands."""

import re
from pathlib import Path

from mfcontrol.config.options import options_markdown

ROOT = Path(__file__).resolve().parents[1]


def test_readme_option_table_is_the_schema():
    assert options_markdown() in (ROOT / "README.md").read_text(encoding="utf-8")


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


def test_guide_pages_include_readme_sections_that_exist():
    """The guide's pages are the README's sections between <!-- docs: NAME --> markers:
    each marker a page names exists once in the README (a renamed marker would fail the
    build; this says which)."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    pages = [*(ROOT / "docs" / "guide").glob("*.md"), ROOT / "docs" / "index.md"]
    named = set()
    for page in pages:
        named |= set(re.findall(r'"(<!-- docs: [a-z-]+ -->)"', page.read_text()))
    assert named and all(readme.count(marker) == 1 for marker in named), named
    assert named == set(re.findall(r"<!-- docs: [a-z-]+ -->", readme))


def test_readme_plant_example_runs(tmp_path, monkeypatch):
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    blocks = text.split("```python\n")[1:]
    code = next(b.split("```")[0] for b in blocks if "plant = ODE(" in b)
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile(code, "README.md", "exec"), namespace)  # noqa: S102
    assert namespace["res"].metrics["stable"] and namespace["res"].engine == "compiled"
    assert (tmp_path / "motor.png").exists()
    table = namespace["sweep"].to_pandas()
    assert len(table) == 12 and table["stable"].any()


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
