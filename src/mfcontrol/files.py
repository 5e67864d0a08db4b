"""Files written whole or not at all.

A file is written into a temporary file of this process beside it, then renamed over
it: a reader (pandas, a resumed sweep) sees the old file or the new one, never half of
one, and a full disk or a kill leaves the old file (or none) and at most a temporary
``.NAME.PID.tmp``, which a sweep removes when it resumes its folder. Numbers for a JSON
file go through :func:`json_number`.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any


def temporary(path: Path) -> Path:
    """The temporary file this process writes ``path`` through."""
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def replace_with(path: str | Path, write: Callable[[Path], Any]) -> None:
    """Write ``path`` atomically: ``write(tmp)`` writes the temporary file, renamed over
    ``path`` once it is whole (removed if writing it failed)."""
    path = Path(path)
    tmp = temporary(path)
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_text(path: str | Path, text: str) -> None:
    """``Path.write_text`` (UTF-8), atomically."""
    replace_with(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def json_number(v: float) -> float | str | None:
    """A number for a JSON file: an infinity as the string ``"inf"`` (``"-inf"``), which
    JSON has no literal for; NaN (not defined, not evaluated) as null."""
    if math.isnan(v):
        return None
    return v if math.isfinite(v) else ("inf" if v > 0 else "-inf")
