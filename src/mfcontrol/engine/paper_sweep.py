"""The sweep kernel: blocks of members of the buck under the paper's law.

Every per-member quantity lives in one array ``D[row, j]`` (a block of :data:`BLOCK`
members), so the member loop addresses one block of memory at compile-time offsets: the
compiler needs no run-time alias checks, and the loop of the scalar step functions
(``recursive_ip.advance``, ``buck.rk4``, ``metrics.accumulate``/``metrics.fold_metrics``,
``metrics.loop_sums``, the ones a single run inlines) vectorises over members.

Tiles. The samples run in tiles of :data:`TILE`, which also end where a metric window
starts (so that a tile lies wholly inside or outside each window) and before a scheduled
change. The first ``recursive_ip.STEADY`` samples and any tile in which a member went bad
run sample by sample with the divergence test of a single run. Every other tile runs the
plain loop: the law at ``k = STEADY`` (the same values from then on, so its start-up
branches compile out), plain metric sums, one max |e| for the tile (folded into the
windows it lies in at its end) and a count of samples with |y| over the bound. A y or u
that is not finite stays so (NaN and inf absorb), and shows at the tile's end in the sums
or in the carried u. A member with a bad sample sends the whole block back to the tile's
snapshot for the sample-by-sample rerun, which finds the exact sample; a member that has
diverged keeps the metrics it had then. So every member's metrics are those of its single
run, bit for bit. When every member has the same reference, a plain tile keeps r_{k-1}
and max |r| as per-sample scalars instead of rows.

Specialisation. A sweep varies a few quantities and shares the rest; a parameter row that
every member shares can be compiled in as a constant (``constants``), which removes its
load from every member-sample and lets the compiler fold what depends on it. The
arithmetic is unchanged: a constant gives the same IEEE result as the value loaded.

Fast mode (``fast=True``). LLVM's ``contract``, ``arcp`` and ``nsz`` flags (fused
multiply-adds, division by a shared value as multiplication by its reciprocal), and the
plant stepped by its RK4 step written as the linear map it is (:func:`buck.rk4_map`): one
fused step instead of four dependent stages. A member loop is bound by that dependency
chain, not by its arithmetic, so this is most of what makes fast mode about 3x faster. No
longer bit-identical to a single run: within about 1e-13 relative of it on the paper's
cases (tested to 1e-12). NaN and inf keep their IEEE meaning in both modes (the
divergence test relies on them).
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache
from typing import Any

import numba
import numpy as np
from numba import njit

from .. import _jit
from ..laws import recursive_ip, reference, variational_gain
from ..plants import buck
from . import metrics, paper_single

# packed rows of a member
P_PP = 0
P_X = P_PP + buck.N_PARAMS
P_CP = P_X + buck.N_STATE
P_CS = P_CP + recursive_ip.N_PARAMS
P_M = P_CS + recursive_ip.N_STATE
P_APREV = P_M + metrics.N_METRICS
P_BAD = P_APREV + 1  # samples of the current plain tile with |y| over the bound
P_MXT = P_BAD + 1  # max |e| over the current plain tile
P_RK = P_MXT + 1  # fast mode: the RK4 step as a linear map (buck.rk4_map), 6 rows
P_ROWS = P_RK + 6
#: rows that hold parameters (a sweep may share them and compile them in)
PARAM_ROWS = tuple(range(P_PP, P_X)) + tuple(range(P_CP, P_CS))
#: members per packed block (not a power of two times 512 bytes: no 4 KiB set aliasing)
BLOCK = 120
#: LLVM flags of the fast mode (see :mod:`mfcontrol._jit`)
FAST_FLAGS = _jit.FAST_FLAGS


def _row(r):
    """Offset of packed row r in a block: a compile-time constant, so every access is a
    fixed distance from every other and the compiler needs no alias checks."""
    return r * BLOCK


# offsets of the rows the member loop reads and writes
_I, _V = _row(P_X + buck.I_L), _row(P_X + buck.V_C)
_UP, _YP, _RP, _G1, _G2, _ACC, _CNT, _AD = (_row(P_CS + r) for r in (
    recursive_ip.U_PREV, recursive_ip.Y_PREV, recursive_ip.R_PREV, variational_gain.G1,
    variational_gain.G2, variational_gain.ACC, variational_gain.CNT, variational_gain.ADAPT))
(_DIV, _TDIV, _NS, _IAE, _ISE, _ITAE, _MXS, _MXF, _MXR, _TV, _GF, _ADF) = (
    _row(P_M + r) for r in (
        metrics.M_DIVERGED, metrics.M_T_DIVERGE, metrics.M_N_SAMPLES, metrics.M_IAE,
        metrics.M_ISE, metrics.M_ITAE, metrics.M_MAX_E_SETTLED, metrics.M_MAX_E_FINAL,
        metrics.M_MAX_ABS_R, metrics.M_TV, metrics.M_FINAL_GAMMA, metrics.M_ADAPT))
_AP, _BAD, _MXT = _row(P_APREV), _row(P_BAD), _row(P_MXT)
(_EN, _PK, _T10, _T90, _TIN, _TL, _EF, _NF, _IL, _ST0, _SFR, _STO, _LT0) = (
    _row(P_M + r) for r in (
        metrics.M_ENERGY, metrics.M_PEAK, metrics.M_T10, metrics.M_T90, metrics.M_T_IN,
        metrics.M_T_LAST, metrics.M_E_FINAL, metrics.M_N_FINAL, metrics.M_IAE_LOAD,
        metrics.M_STEP_T0, metrics.M_STEP_FROM, metrics.M_STEP_TO, metrics.M_LOAD_T0))


# step_jit: a stable identity, since the tiles close over one of these two (a plain njit
# pickles with an identifier drawn per process, and the tiles then missed numba's disk
# cache in every new process)
@_jit.step_jit
def _loop_sums(D, j, t, h, y, r, a, final_start):
    """:func:`metrics.loop_sums` on member j's packed rows."""
    (D[_EN + j], D[_PK + j], D[_T10 + j], D[_T90 + j], D[_TIN + j], D[_TL + j], D[_EF + j],
     D[_NF + j], D[_IL + j]) = metrics.loop_sums(
        D[_EN + j], D[_PK + j], D[_T10 + j], D[_T90 + j], D[_TIN + j], D[_TL + j],
        D[_EF + j], D[_NF + j], D[_IL + j], t, h, y, r, a, D[_ST0 + j], D[_SFR + j],
        D[_STO + j], D[_LT0 + j], final_start)


@_jit.step_jit
def _loop_sums_without_step(D, j, t, h, y, r, a, final_start):
    """The same for members with no reference step (step_to NaN): the step's rows keep
    their start, as :func:`metrics.loop_sums` leaves them, and a loop over members neither
    computes nor loads nor stores them (the paper's ramps: measured 38-48 against 26-28 ms
    for 480 members of 10,000 samples with them)."""
    (D[_EN + j], _, _, _, _, _, D[_EF + j], D[_NF + j], D[_IL + j]) = metrics.loop_sums(
        D[_EN + j], 0.0, math.inf, math.inf, -math.inf, -math.inf, D[_EF + j], D[_NF + j],
        D[_IL + j], t, h, y, r, a, 0.0, math.nan, math.nan, D[_LT0 + j], final_start)


_F11, _F12, _F21, _F22, _G1D, _G2D = (_row(P_RK + r) for r in range(6))
#: samples per tile: the unchecked loop runs a tile, then looks for a member gone bad
TILE = 256


@njit(inline="always", error_model="numpy")
def _copy_rows(src, src_row, dst, dst_row, n_rows):
    # element loops: an array assignment would compile numba's shape-mismatch message
    # machinery, seconds of compilation for every kernel
    for r in range(n_rows):
        for j in range(src.shape[1]):
            dst[dst_row + r, j] = src[src_row + r, j]


def _reader(name, rows, VARY, K, options):
    """``name(D, j)``: member j's values of the packed ``rows``, as a tuple, a shared row
    as the compile-time constant it holds. Generated from the rows a law or plant
    function declares (``recursive_ip``'s parameter rows, ``buck.RK4_ROWS``), so that a
    parameter added there reaches the sweep kernel without an edit here."""
    items, names = [], {}
    for r in rows:
        if VARY[r]:
            items.append(f"D[{_row(r)} + j]")
        else:  # a global of the generated function: numba compiles it in as a constant
            names[f"c{r}"] = K[r]
            items.append(f"c{r}")
    namespace = {"__name__": __name__, **names}
    exec(f"def {name}(D, j):\n    return ({', '.join(items)},)\n", namespace)
    return njit(inline="always", **options)(namespace[name])


@lru_cache(maxsize=32)
def block_kernel(constants: tuple[float, ...] | None = None, reference_shared: bool = False,
                 fast: bool = False, steps: bool = True):
    """The block loop of a sweep, compiled for what its members share.

    Parameters
    ----------
    constants : tuple of float, optional
        One value per packed row (length :data:`P_ROWS`); NaN where the row is read from
        ``D``. Only :data:`PARAM_ROWS` may be given, and a shared row must hold the same
        value in every member (a scheduled change to it makes it vary). ``None``: every
        row is read (the generic kernel, compiled once and cached on disk).
    reference_shared : bool
        Every member has member 0's reference: evaluated once per sample.
    fast : bool
        Compile with :data:`FAST_FLAGS` instead of exact IEEE arithmetic.
    steps : bool
        Some member's reference is a step (its step metrics are folded); False: none is
        (the step metrics' rows keep their start, as they would).

    Returns
    -------
    callable
        ``run(n_steps, h, t_end, D, RP, ev_steps, ev_k, ev_row, ev_add, ev_val, S)`` that
        runs every block ``D[b]`` (shape ``(n_blocks, P_ROWS, BLOCK)``) from sample 0, on
        all cores, and leaves each member's metrics in its rows ``P_M ..``.
    """
    if constants is None:
        constants = (math.nan,) * P_ROWS
    if len(constants) != P_ROWS or any(not math.isnan(c) for r, c in enumerate(constants)
                                       if r not in PARAM_ROWS):
        raise ValueError("constants: one value per packed row, NaN outside the parameters")
    VARY = tuple(math.isnan(c) for c in constants)
    K = tuple(0.0 if math.isnan(c) else float(c) for c in constants)
    SHARED_REF = bool(reference_shared)
    # the derived coefficients are recomputed from D only where one of their sources varies
    PREPARE = any(VARY[P_PP + r] for r in (buck.L, buck.R, buck.C))
    # fast mode also steps the plant by its linear RK4 map: one fused step instead of
    # four dependent stages, which is what bounds a member loop (its latency, not its
    # arithmetic)
    MATRIX = bool(fast)
    # the constant gain leaves gamma_k = 1/alpha in G1 and G2 at every k >= STEADY: a
    # plain tile need not store them
    CONSTANT_GAIN = (not VARY[P_CP + variational_gain.MODE]
                     and K[P_CP + variational_gain.MODE] == variational_gain.CONSTANT)
    # the multi-rate sum and count move only when some member updates gamma every m > 1
    # samples: otherwise a tile need not store them (they stay as reset left them)
    MULTI_RATE = not CONSTANT_GAIN and (VARY[P_CP + variational_gain.EVERY]
                                        or K[P_CP + variational_gain.EVERY] > 1.0)
    flags = _jit.FASTMATH if fast else False
    options: dict[str, Any] = dict(error_model="numpy", fastmath=flags)

    # member j's arguments of buck.rk4 / rk4_map after the state, of buck.measure, and
    # of recursive_ip.advance after its state
    plant = _reader("plant", [P_PP + r for r in buck.RK4_ROWS], VARY, K, options)
    output = _reader("output", [P_PP + buck.OUTPUT], VARY, K, options)
    law = _reader("law", [P_CP + r for r in range(recursive_ip.N_PARAMS)], VARY, K, options)

    @njit(inline="always", **options)
    def prepare(D, PP, h):
        """The derived plant coefficients of every member after a parameter change."""
        for j in range(BLOCK):
            if PREPARE:
                buck.prepare(PP, j)
            if MATRIX:
                ind, e_in, a12, a21, a22, cpl = plant(D, j)
                (D[_F11 + j], D[_F12 + j], D[_F21 + j], D[_F22 + j], D[_G1D + j],
                 D[_G2D + j]) = buck.rk4_map(ind, e_in, a12, a21, a22, cpl, h)

    # what the closures below are built from: their identity for numba's disk cache
    STEPS = bool(steps)
    loop_fold = _loop_sums if STEPS else _loop_sums_without_step
    identity = (constants, SHARED_REF, MATRIX, STEPS)
    _jit.stable_identity(plant, identity)
    _jit.stable_identity(prepare, identity)
    _jit.stable_identity(law, identity)
    _jit.stable_identity(output, identity)

    # every kernel, specialised or not, exact or fast, is cached on disk: what a closure is
    # built from enters numba's cache key through its cells (VARY, K, the flags) and the
    # identities above (the constants), so each set of shared values has its own entry
    def make_tile(checked):
        # a shared reference in a plain tile: r_{k-1} and max |r| are per-sample scalars,
        # not rows every member reads and writes
        HOIST = SHARED_REF and not checked

        @njit(cache=True, **options)
        def tile(D, RP, R, T, k0, k1, h, settle, final_start, bound):
            """Samples k0 .. k1-1 (at times T[k]) of every member of the block:
            measurement, law (at sample kl), metrics, plant step. ``checked``: the
            divergence test at every sample (:func:`metrics.fold_metrics`); otherwise the
            plain sums, the tile's max |e| and a count of samples with |y| over the bound,
            which the tile's end inspects."""
            r = 0.0
            r_prev = D[_RP]  # shared reference: every member's r_{k-1} is member 0's
            max_r = 0.0
            for k in range(k0, k1):
                t = T[k]
                if SHARED_REF:
                    r = reference.value(RP, 0, t)
                    max_r = np.fmax(abs(r), max_r)
                else:
                    for j in range(BLOCK):
                        R[j] = reference.value(RP, j, t)
                kl = float(k) if checked else recursive_ip.STEADY
                for j in range(BLOCK):
                    if not SHARED_REF:
                        r = R[j]
                    i, v = D[_I + j], D[_V + j]
                    y = buck.measure(i, v, output(D, j)[0])
                    u, a, g, gamma, carried, g1, g2, acc, cnt, adapt = recursive_ip.advance(
                        kl, y, r, D[_UP + j], D[_YP + j], (r_prev if HOIST else D[_RP + j]),
                        D[_G1 + j], D[_G2 + j], D[_ACC + j], D[_CNT + j], D[_AD + j],
                        law(D, j))
                    D[_UP + j], D[_YP + j] = carried, y
                    if not HOIST:
                        D[_RP + j] = r
                    if checked or not CONSTANT_GAIN:
                        D[_G1 + j], D[_G2 + j], D[_AD + j] = g1, g2, adapt
                    if MULTI_RATE:
                        D[_ACC + j], D[_CNT + j] = acc, cnt
                    if checked:
                        (alive, D[_TDIV + j], D[_NS + j], D[_IAE + j], D[_ISE + j], D[_ITAE + j],
                         D[_MXS + j], D[_MXF + j], D[_MXR + j], D[_TV + j],
                         D[_GF + j]) = metrics.fold_metrics(
                            1.0 - D[_DIV + j], D[_TDIV + j], D[_NS + j], D[_IAE + j], D[_ISE + j],
                            D[_ITAE + j], D[_MXS + j], D[_MXF + j], D[_MXR + j], D[_TV + j],
                            D[_GF + j], k, t, h, y, r, u, a, D[_AP + j], gamma, settle, final_start,
                            bound)
                        D[_DIV + j] = 1.0 - alive
                        if alive != 0.0:
                            loop_fold(D, j, t, h, y, r, a, final_start)
                            D[_ADF + j] = adapt  # as the final gamma
                    else:
                        # the tile lies wholly inside or outside each metric window
                        # (run_block splits tiles at their starts): one max |e| for the
                        # tile, folded into the windows at its end; and k >= STEADY > 0
                        e = y - r
                        ae = abs(e)
                        (D[_IAE + j], D[_ISE + j], D[_ITAE + j], D[_TV + j]) = metrics.sums(
                            D[_IAE + j], D[_ISE + j], D[_ITAE + j], D[_TV + j], t, h, e, ae,
                            abs(a - D[_AP + j]))
                        D[_MXT + j] = np.fmax(ae, D[_MXT + j])
                        if not HOIST:
                            D[_MXR + j] = np.fmax(abs(r), D[_MXR + j])
                        # a count, not a sticky maximum: a select on the stored value
                        # would become a masked store (see metrics.accumulate). A y or u
                        # that is not finite stays so (NaN and inf absorb): the tile's
                        # end sees it in the sums or in the carried u
                        D[_BAD + j] += 1.0 if abs(y) > bound else 0.0
                        loop_fold(D, j, t, h, y, r, a, final_start)
                    D[_AP + j] = a
                    if MATRIX:
                        D[_I + j], D[_V + j] = buck.rk4_linear(
                            i, v, a, D[_F11 + j], D[_F12 + j], D[_F21 + j], D[_F22 + j],
                            D[_G1D + j], D[_G2D + j])
                    else:
                        ind, e_in, a12, a21, a22, cpl = plant(D, j)
                        D[_I + j], D[_V + j] = buck.rk4(i, v, a, ind, e_in, a12, a21, a22,
                                                        cpl, h)
                if HOIST:
                    r_prev = r
            if not checked:
                for j in range(BLOCK):
                    if HOIST:
                        D[_RP + j] = r_prev
                        D[_MXR + j] = np.fmax(max_r, D[_MXR + j])
                    # the law leaves gamma_k in G1 at every k >= 1: the final gamma is
                    # read once per tile instead of stored at every sample
                    D[_GF + j] = D[_G1 + j]
                    D[_ADF + j] = D[_AD + j]
        _jit.stable_identity(tile, identity, checked)
        return tile

    # two compiled loops: sample by sample with the divergence test, and the plain one
    tile_checked, tile_plain = make_tile(True), make_tile(False)

    @njit(nogil=True, cache=True, **options)
    def run_block(T, h, k_settle, k_final, D2, RP, ev_steps, ev_k, ev_row, ev_add, ev_val, S):
        n_steps = T.size
        D = D2.ravel()
        R = np.empty(BLOCK)
        PP = D2[P_PP:P_X]
        snapshot = np.empty((P_ROWS - P_X, BLOCK))
        frozen = np.empty((metrics.N_METRICS, BLOCK))
        dead = np.zeros(BLOCK, dtype=np.bool_)
        settle, final_start, bound = (S[metrics.S_SETTLE], S[metrics.S_FINAL_START],
                                      S[metrics.S_DIVERGE_ABOVE])
        prepare(D, PP, h)
        p_ev = 0
        k0 = n_steps * 0  # an int64 from the start: a literal 0 would compile the tiles twice
        while k0 < n_steps:
            if p_ev < ev_steps.size and ev_steps[p_ev] == k0:
                paper_single.apply_events(k0, ev_k, ev_row, ev_add, ev_val, PP, BLOCK)
                prepare(D, PP, h)
                p_ev += 1
            # a tile ends before the next scheduled change, so that a rerun of it sees
            # the parameters it ran with, and where a metric window starts
            k1 = min(n_steps, k0 + TILE)
            if p_ev < ev_steps.size:
                k1 = min(k1, ev_steps[p_ev])
            if k0 < k_settle:
                k1 = min(k1, k_settle)
            if k0 < k_final:
                k1 = min(k1, k_final)
            checked = k0 < recursive_ip.STEADY
            if checked:
                k1 = min(k1, int(recursive_ip.STEADY))
            else:
                _copy_rows(D2, P_X, snapshot, 0, P_ROWS - P_X)
                for j in range(BLOCK):
                    D[_BAD + j] = 0.0
                    D[_MXT + j] = 0.0
                tile_plain(D, RP, R, T, k0, k1, h, settle, final_start, bound)
                for j in range(BLOCK):
                    # a y that was not finite left the sums so, a u the carried u
                    if not dead[j] and (D[_BAD + j] != 0.0 or not (
                            np.isfinite(D[_IAE + j]) and np.isfinite(D[_ISE + j])
                            and np.isfinite(D[_UP + j]))):
                        checked = True
                if checked:  # some member went bad in this tile: rerun it sample by sample
                    _copy_rows(snapshot, 0, D2, P_X, P_ROWS - P_X)
                else:
                    for j in range(BLOCK):
                        # the samples done so far: a member that goes bad on the next
                        # tile's first sample keeps this count
                        D[_NS + j] = k1
                        if k0 >= k_settle:
                            D[_MXS + j] = np.fmax(D[_MXT + j], D[_MXS + j])
                        if k0 >= k_final:
                            D[_MXF + j] = np.fmax(D[_MXT + j], D[_MXF + j])
            if checked:
                tile_checked(D, RP, R, T, k0, k1, h, settle, final_start, bound)
                for j in range(BLOCK):
                    if D[_DIV + j] != 0.0 and not dead[j]:
                        dead[j] = True
                        for m in range(metrics.N_METRICS):
                            frozen[m, j] = D2[P_M + m, j]
            k0 = k1
        # a live member's sample count is n_steps now (the last tile set it, plain or
        # checked); a dead one's metrics were written over by the plain tiles after its
        # divergence
        for j in range(BLOCK):
            if dead[j]:
                for m in range(metrics.N_METRICS):
                    D2[P_M + m, j] = frozen[m, j]

    def run(n_steps, h, t_end, D, RP, ev_steps, ev_k, ev_row, ev_add, ev_val, S):
        # the sample times once, in exact arithmetic whatever the mode: a tile's window
        # split and its samples' window weights then agree
        T = (np.arange(n_steps) * t_end) / n_steps
        k_settle, k_final = np.searchsorted(T, [S[metrics.S_SETTLE], S[metrics.S_FINAL_START]])

        def one(b):
            run_block(T, h, int(k_settle), int(k_final), D[b], RP[b], ev_steps, ev_k[b], ev_row,
                      ev_add, ev_val[b], S)
        workers = min(numba.get_num_threads(), D.shape[0])
        if workers <= 1:
            for b in range(D.shape[0]):
                one(b)
            return
        # the block loop releases the GIL: plain threads keep every core busy, and
        # compile in a fraction of the time of a parallel (prange) kernel
        with ThreadPoolExecutor(workers) as pool:
            list(pool.map(one, range(D.shape[0])))

    return run


def shared_constants(D: np.ndarray, varying: set[int]) -> tuple[float, ...]:
    """The ``constants`` of :func:`block_kernel` for the members ``D[row, j]`` of a
    sweep: member 0's value of every parameter row except the rows in ``varying`` (those
    a swept key or a scheduled change writes) and the coefficients derived from them."""
    varying = set(varying)
    if varying & {P_PP + buck.L, P_PP + buck.R, P_PP + buck.C}:
        varying |= {P_PP + buck.A12, P_PP + buck.A21, P_PP + buck.A22}
    out = [math.nan] * P_ROWS
    for r in PARAM_ROWS:
        if r not in varying:
            out[r] = float(D[r, 0])
    return tuple(out)
