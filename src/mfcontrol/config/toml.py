"""TOML in and out: nested tables to dotted keys, ``key=value`` from the command line, and a
resolved configuration written back as TOML."""

from __future__ import annotations

import tomllib
from collections.abc import Mapping
from typing import Any

from ..errors import ConfigError


def flatten(table: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested TOML tables to dotted keys."""
    flat: dict[str, Any] = {}
    for k, v in table.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping):
            flat.update(flatten(v, key + "."))
        else:
            flat[key] = v
    return flat


def parse_assignment(text: str) -> tuple[str, Any]:
    """``key=value`` from the command line; the value is read as a TOML value when it is one
    (numbers, true/false, lists), else taken as a bare string."""
    key, sep, raw = text.partition("=")
    key, raw = key.strip(), raw.strip()
    if not sep or not key:
        raise ConfigError(text, text, "expected key=value")
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    except ValueError:  # an integer past Python's int-to-str limit (4,300 digits)
        raise ConfigError(key, f"{raw[:20]}... ({len(raw)} characters)", "is too long a "
                          "number: options are numbers within the float range") from None
    except RecursionError:
        raise ConfigError(key, f"{raw[:20]}...", "is nested too deeply: options are numbers, "
                          "strings, true/false or lists of numbers") from None
    return key, value


_TOML_ESCAPES = {"\\": "\\\\", '"': '\\"', "\b": "\\b", "\t": "\\t", "\n": "\\n",
                 "\f": "\\f", "\r": "\\r"}


def _toml_char(ch: str) -> str:
    """One character of a TOML basic string: control characters must be escaped."""
    if ch in _TOML_ESCAPES:
        return _TOML_ESCAPES[ch]
    return f"\\u{ord(ch):04x}" if ord(ch) < 0x20 or ord(ch) == 0x7F else ch


def toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return '"' + "".join(_toml_char(ch) for ch in v) + '"'
    if isinstance(v, list | tuple):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, Mapping):
        return "{" + ", ".join(f"{k} = {toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"cannot write {v!r} as TOML")


def to_toml(nested: Mapping[str, Any]) -> str:
    """Write a two-level mapping (top keys, then tables) as TOML."""
    lines = [f"{k} = {toml_value(v)}" for k, v in nested.items() if not isinstance(v, dict)]
    for k, v in nested.items():
        if isinstance(v, dict):
            lines.append(f"\n[{k}]")
            lines.extend(f"{kk} = {toml_value(vv)}" for kk, vv in v.items())
    return "\n".join(lines) + "\n"
