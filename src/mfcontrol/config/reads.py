"""The refusal of an option that is set but that nothing will read: a key the run would
not read is an error that says why and what to set, never dropped in silence.

What reads a key is found by running the translators (:func:`.resolve.keys_read`): a
caller passes that as ``reads`` (a run's, :func:`mfcontrol.api.run.simulate.keys_read_by_run`;
a controller's; a loop element's). This module only finds and words the way out: the
choices (``controller.law``, ``sensor.noise``, ``disturbance.kind``, ...) whose other
values would have the key read, one choice or a choice and one it brings in (the law,
then its estimator)."""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterator, Mapping, Sequence
from typing import Any

from ..errors import ConfigError
from .options import BY_KEY, OPTIONS
from .resolve import Config
from .toml import toml_value

#: what a caller says reads a configuration's keys
Reads = Callable[[Config], Collection[str]]

#: the options whose value decides which others are read: every choice
CHOICES: tuple[str, ...] = tuple(o.key for o in OPTIONS if o.choices or o.kind == "bool")


#: keys read by one command only: (key or section, the command)
_OTHER_COMMANDS = (("benchmark.", "mfcontrol benchmark"), ("sweep.grid", "mfcontrol sweep"))


def _values(key: str) -> list[Any]:
    o = BY_KEY[key]
    if o.kind == "bool":
        return [True, False]
    return [int(c) for c in o.choices] if o.kind == "int" else list(o.choices)


def _alternatives(cfg: Config, keys: Sequence[str]
                  ) -> Iterator[tuple[str, Any, str | None, Config]]:
    """Each other value of each choice of ``keys``, with the set key it conflicts with (a
    plant's schedule of another plant's parameters: unset then) or None, and the
    configuration it makes; values the checks across options refuse otherwise are left
    out."""
    for key in keys:
        for v in _values(key):
            if v == cfg[key]:
                continue
            try:
                yield key, v, None, cfg.with_overrides({key: v})
            except ConfigError as exc:
                if exc.key == key or exc.key not in cfg.explicit:
                    continue
                try:
                    yield key, v, exc.key, cfg.with_overrides({key: v, exc.key: None})
                except ConfigError:
                    continue


def why_unread(cfg: Config, key: str, reads: Reads, *, instead: str = "remove it",
               among: Sequence[str] = CHOICES, name: Callable[[str], str] = str,
               by: str = "this run") -> str:
    """Why ``key`` is not read under ``cfg``, what to set for it to be, and ``instead``,
    in words (the ``allowed`` of a :class:`ConfigError`): ``not read with controller.law
    = "i-P": set controller.law = "i-PI", "i-PID" or "pid", or remove it``. The ways out
    are the choices of ``among`` that ``cfg``'s run reads (a choice it does not read
    cannot change what it reads), set alone or with a choice the first brings in (the
    law, then its estimator); ``name`` writes a key as the caller's user knows it (a
    keyword argument: ``gamma0``). With no way out, the option's own meaning says what it
    is for."""
    before = set(reads(cfg))
    singles: list[tuple[str, Any, str | None]] = []
    chains: list[tuple[str, Any, str | None, str, Any]] = []
    tried = []
    for c, v, dropped, other in _alternatives(cfg, [k for k in among if k in before]):
        now = set(reads(other))
        if key in now:
            singles.append((c, v, dropped))
        tried.append((c, v, dropped, other, now))
    for c, v, dropped, other, now in tried if not singles else ():
        brought = [k for k in among if k in now - before]
        chains += [(c, v, dropped, c2, v2) for c2, v2, d2, third in _alternatives(other, brought)
                   if d2 is None and key in reads(third)]
    if not singles and not chains:
        command = next((c for head, c in _OTHER_COMMANDS if key.startswith(head)), None)
        if command:
            return f"read by {command} only, not by {by}: {instead}"
        return f"not read by {by} ({BY_KEY[key].doc}): {instead}"

    def setting(k: str, values: list[Any]) -> str:
        shown = [toml_value(v) for v in values]
        text = shown[0] if len(shown) == 1 else f"{', '.join(shown[:-1])} or {shown[-1]}"
        return f"{name(k)} = {text}"

    # grouped by the first choice (and what it unsets), then by the second of a chain
    ways: dict[tuple, list[Any]] = {}
    if singles:
        for c, v, dropped in singles:
            ways.setdefault((c, dropped), []).append(v)
    else:
        for c, v, dropped, c2, v2 in chains:
            ways.setdefault((c, dropped, c2, v2), []).append(v)
    firsts = list(dict.fromkeys(w[0] for w in ways))
    now_set = " and ".join(f"{name(c)} = {toml_value(cfg[c])}" for c in firsts)
    sets = " or ".join(
        setting(w[0], vs) + (f" with {setting(w[2], [w[3]])}" if len(w) > 2 else "")
        + (f" (and unset {name(w[1])})" if w[1] else "") for w, vs in ways.items())
    return f"not read with {now_set}: set {sets}, or {instead}"


def refuse_unread(cfg: Config, keys: Collection[str] | Mapping[str, Any], reads: Reads, *,
                  read: Collection[str] | None = None, instead: str = "remove it",
                  among: Sequence[str] = CHOICES, name: Callable[[str], str] = str,
                  by: str = "this run") -> None:
    """Raise a :class:`ConfigError` for the first of ``keys`` (in the option table's
    order) that ``reads(cfg)`` (or ``read``, when the caller has it) does not hold: one
    line naming the key, its value (``keys``'s, where it maps them, else ``cfg``'s) and
    :func:`why_unread`."""
    read = set(reads(cfg)) if read is None else read
    for key in (o.key for o in OPTIONS if o.key in keys and o.key not in read):
        value = keys[key] if isinstance(keys, Mapping) else cfg[key]
        raise ConfigError(name(key), value, why_unread(cfg, key, reads, instead=instead,
                                                       among=among, name=name, by=by))
