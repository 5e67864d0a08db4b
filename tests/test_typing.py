"""The package type-checks: mypy, with the configuration of pyproject.toml, over
mfcontrol and tests/typing_usage.py (the public API used as a user uses it, each value
annotated with the type a user expects), reports no error."""

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_mypy_finds_no_error(monkeypatch):
    api = pytest.importorskip("mypy.api")
    monkeypatch.chdir(ROOT)  # mypy reads pyproject.toml's paths from the repository root
    stdout, stderr, status = api.run(["--config-file", "pyproject.toml",
                                      "src/mfcontrol", "tests/typing_usage.py"])
    assert status == 0 and "Success: no issues found" in stdout, \
        f"mypy exited {status}:\n{stdout}{stderr}"
