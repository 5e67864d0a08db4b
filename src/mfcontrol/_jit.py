"""Compilation settings shared by every compiled function of the package.

``error_model='numpy'`` lets a division by zero give inf/NaN instead of raising, which
keeps the kernels branch-free (so they vectorise) and turns a blow-up into data that the
engine flags. No fastmath: the published results are reproduced bit for bit, and LLVM
must not fuse multiply-adds or reorder sums behind our back. (The exceptions are the
opt-in fast modes, ``mfcontrol sweep --fast`` and ``simulate(cfg, fast=True)``, which
say so.)
"""

import hashlib
import os
from collections import OrderedDict
from collections.abc import Callable, Hashable
from pathlib import Path
from typing import Any

from numba import njit
from numba.core.caching import FunctionCache, IndexDataCacheFile


def _drop_stale_cache() -> None:
    """numba keys a cached function on its own file's time stamp only, so a kernel would
    keep an inlined law from before an edit of the law's file. Hash every source file of
    the package; when the hash differs from the one recorded with the cache, delete the
    package's cached objects so that everything recompiles. A no-op for an installed
    release, whose sources never change."""
    pkg = Path(__file__).resolve().parent
    digest = hashlib.sha256()
    for path in sorted(pkg.rglob("*.py")):
        digest.update(path.relative_to(pkg).as_posix().encode())
        digest.update(path.read_bytes())
    stamp = digest.hexdigest()
    roots = [pkg]
    if os.environ.get("NUMBA_CACHE_DIR"):
        roots.append(Path(os.environ["NUMBA_CACHE_DIR"]))
    marker = pkg / "__pycache__" / "numba-source.sha256"
    try:
        if marker.exists() and marker.read_text() == stamp:
            return
        for root in roots:
            for pattern in ("*.nbi", "*.nbc"):
                for f in root.rglob(pattern):
                    if "mfcontrol" in f.as_posix():
                        f.unlink(missing_ok=True)
        marker.parent.mkdir(exist_ok=True)
        marker.write_text(stamp)
    except OSError:
        pass  # a read-only install: its sources cannot have changed either


_drop_stale_cache()


def stable_identity(dispatcher, *key) -> None:
    """Let numba's disk cache find a kernel that calls this closure.

    numba keys a cached closure on its cell contents, pickled. A compiled closure in a cell
    pickles with an identifier drawn at random in each process, so a kernel built from
    such closures never finds its cached code and recompiles in every process (about 3 s
    for the sweep kernel). Give the closure an identifier derived from its name and from
    ``key``, what the factory built it from; call this right after creating it."""
    text = repr((dispatcher.py_func.__module__, dispatcher.py_func.__qualname__) + key)
    dispatcher._set_uuid("mfcontrol-" + hashlib.sha256(text.encode()).hexdigest())


class IdentityCache(FunctionCache):
    """numba's disk cache of a compiled closure, keyed on ``identity`` (a digest of what the
    closure's compiled code depends on) instead of its cells, pickled.

    For closures over your own functions (:mod:`mfcontrol.plants.ode`): pickled, a cell's
    function would give a key that changes from process to process, or fails. Each
    identity has index and data files of its own: numba's index is read, extended and
    written back without a lock, so two processes saving different keys to one index at
    once could leave a key naming the other's data file (the wrong code, loaded later).
    Two processes saving the same identity write the same entry. Like any numba cache,
    the index is dropped when the closure's own file changes (and the package's, by
    :func:`_drop_stale_cache`)."""

    def __init__(self, py_func: Callable[..., Any], identity: str):
        super().__init__(py_func)
        self._identity = identity
        self._cache_file = IndexDataCacheFile(
            cache_path=self._cache_path,
            filename_base=f"{self._impl.filename_base}-{identity[:24]}",
            source_stamp=self._impl.locator.get_source_stamp())

    def _index_key(self, sig, codegen):
        code = hashlib.sha256(self._py_func.__code__.co_code).hexdigest()
        return (sig, codegen.magic_tuple(), (code, self._identity))


class Recent:
    """What was last built for up to ``size`` keys, the oldest forgotten first: compiled
    functions that a new object built from the same functions reuses."""

    def __init__(self, size: int = 64):
        self._size = size
        self._items: OrderedDict[Hashable, Any] = OrderedDict()

    def get(self, key: Hashable, build: Callable[[], Any]) -> Any:
        """The value kept for ``key``, or ``build()``, kept (an exception keeps nothing)."""
        if key in self._items:
            self._items.move_to_end(key)
            return self._items[key]
        value = self._items[key] = build()
        if len(self._items) > self._size:
            self._items.popitem(last=False)
        return value


#: LLVM flags of the opt-in fast mode (sweeps and single runs): fused multiply-adds,
#: reciprocals of shared divisors, no signed-zero care. No ``nnan``/``ninf`` (the
#: divergence test needs NaN and inf), no ``reassoc`` (a reordered sum drifts further).
FAST_FLAGS = ("contract", "arcp", "nsz")
#: the same as numba's ``fastmath`` option. A dict, not a set: a compiled function that
#: calls a fast one pickles the callee's options into its disk-cache key, and a set of
#: strings pickles in an order that changes with every process's string hashing (the
#: fast kernels then missed the cache in every new process)
FASTMATH: Any = dict.fromkeys(FAST_FLAGS, True)  # numba's stubs say set; it takes a dict
#: Kernels of the fast mode: compiled on first use, cached on disk.
fast_kernel_jit = njit(error_model="numpy", cache=True, fastmath=FASTMATH)

_step_jit = njit(inline="always", error_model="numpy", cache=True)


def step_jit(fn):
    """Small step functions: inlined into every kernel that calls them. Each has an
    identity derived from its module and name (:func:`stable_identity`): a compiled
    closure that calls one (a plant's block functions) pickles it into its cache key."""
    dispatcher = _step_jit(fn)
    stable_identity(dispatcher)
    return dispatcher


#: Kernels: compiled once, cached on disk next to the package.
kernel_jit = njit(error_model="numpy", cache=True)
