"""The README states what the code does: its option table and quick-start commands."""

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
