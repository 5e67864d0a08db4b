"""Algebraic integral estimator of F over a sliding window of M samples, T = M h.

Ultra-local model ``y^(n) = F + alpha u`` (n = 1 or 2), samples at t_i = i h. At sample k
the window holds y_{k-M}, ..., y_k and u_{k-M}, ..., u_{k-1} (u_i is applied from t_i on).
In the window s runs from 0 at the OLDEST sample to T at the newest (s_i = i h, sample
k - M + i). With w(s) a kernel vanishing at both ends, integration by parts moves the
derivatives of y onto w, where they are exact::

    n = 1, w = s (T - s):  int w' y = -int w y' = -int w (F + alpha u), int w = T^3 / 6
        F_hat = -(6 / T^3) int_0^T [ (T - 2 s) y(t-T+s) + alpha s (T - s) u(t-T+s) ] ds
    n = 2, w = s^2 (T - s)^2 / 2 (w' vanishes at the ends too), int w = T^5 / 60
        F_hat = (60 / T^5) int_0^T [ (T^2 - 6 T s + 6 s^2) y(t-T+s)
                                      - (alpha / 2) s^2 (T - s)^2 u(t-T+s) ] ds

Three kernels, the discretisations of the integral and a delay-reduced one (``kernel``):

``trapezoid`` (the literature's, in most published MFC code)
    The trapezoid rule (n = 1) and composite Simpson (n = 2, M even) over the M + 1
    samples, u_i standing for u(t_i). It is *not* exact for a constant F: the rule treats
    the held input u_j as a node value, half a sample out of line with y, and adds its own
    error to the y part. With F constant and u constant the estimate is
    ``F + (2 F + 3 alpha u) / M^2`` (n = 1); under a varying held input the error is about
    ``0.8 alpha |du| / M``. In a loop this gives the i-P a finite DC gain
    ``kp M^2 / alpha`` and a steady-state error ``-alpha u / (kp M^2)``.
``held`` (exact under a zero-order hold)
    Between samples a held input makes y' = F + alpha u_j (n = 1) constant, so
    ``(y_{j+1} - y_j) / h - alpha u_j = F`` exactly, and for n = 2
    ``(y_{j+2} - 2 y_{j+1} + y_j) / h^2 - alpha (u_j + u_{j+1}) / 2 = F``. The kernel is
    the weighted mean of these exact relations over the window, weighted by the integral's
    w at each relation's centre (``v_j ~ w(s_{j+1/2})`` for n = 1, ``w(s_{j+1})`` for
    n = 2): the same smoothing as the integral, and F_hat = F to rounding for any held
    input when F is constant. M may be odd for n = 2.

Both weigh the window symmetrically about its centre: for F linear in time the estimate
is F(t - T/2), delayed by half a window. Both need only u up to u_{k-1}.

``delay-reduced`` (n = 1; Mboup, Join and Fliess's affine Jacobi estimators on the held
relations)
    Under a held input each relation ``phi_j = (y_{j+1} - y_j) / h - alpha u_j`` is the
    mean of F over its interval, which for F affine in time is F at the interval's centre
    x_j exactly (x_j = j + 1/2 - M/2, centred sample units, +M/2 the newest end). The
    kernel is the w-weighted least-squares line through them, evaluated at
    ``x* = M/2 - lag``, with the Jacobi weight ``w(x) = (M/2 - x)^kappa (M/2 + x)^mu``:
    phi_j weighs ``w_j [1/W + (x* - xbar)(x_j - xbar)/S]`` (W = sum w, xbar = sum w x / W,
    S = sum w (x - xbar)^2), the truncation q = 1 of the weight's Jacobi expansion. In
    the local time tau = (t_k - t)/T, back from the newest sample, the weight is
    tau^kappa (1 - tau)^mu: kappa at the newest end, mu at the oldest (the literature
    writes the family with either end first: compare a published choice by its
    weight). kappa = mu = 1 (the default) is the held kernel's weight, and
    ``lag = M/2`` then gives the held kernel; ``lag = M/2 - xbar`` drops the slope (the
    weighted mean, q = 0). F_hat = F(t_k - lag h) exactly for F affine in time, under any
    held input, for any lag from 0 to M (any point of the window). The u weights are of
    degree kappa + mu + 1 in the centred index and the y weights of kappa + mu, so with
    order 2's moments (:func:`moment_order`) the kernel slides in O(1) for
    kappa + mu <= 2 (:data:`MAX_JACOBI`). Its coefficients of the moments are computed
    once, in exact rationals, where the parameters are built (:func:`jacobi_rows`), and
    kept in the law's parameter rows: each member of a sweep has its own. The noise it
    passes (white sensor noise: the root sum of squares of the y weights) is 2.1 times
    the held kernel's at lag M/4 and 3.9 times at lag 0 for kappa = mu = 1 (M = 20; it
    tends to 4 as M grows), more for the other weights (docs/theory.md's table,
    ``benchmarks/jacobi_noise.py``).

Sliding moments
---------------
In the centred window index c = i - M/2 both kernels are polynomials in c::

    n = 1:  y weight ~ -2 c              u weight ~ M^2/4 - c^2
    n = 2:  y weight ~ 6 c^2 - M^2/2     u weight ~ (M^2/4 - c^2)^2

and the held kernels (u at its own centred index, c = j - M/2 for u_j)::

    n = 1:  y weight ~ 2 c              u weight ~ M^2/4 - (c + 1/2)^2
    n = 2:  y weight ~ 12 c^2 + 2 - M^2 u weight ~ g(c) + g(c + 1), g(c) = (M^2/4 - c^2)^2

so F_hat is a fixed combination of the moments ``Y_p = sum c^p y`` (p <= 2) and
``U_p = sum c^p u`` (p <= 4), plus end corrections, which need only the oldest and
newest y. When the window slides by one sample every c drops by one, so
``Y_p <- sum_q C(p, q) (-1)^(p-q) Y_q``, less the sample leaving, plus the one entering:
O(1) work per sample whatever M. Simpson's 1-4-2-...-4-1 pattern needs separate sums over
even and odd positions; a sample's position changes parity at every slide, its absolute
index does not, so the sums are split by the parity of the absolute sample index. Centring
keeps the moments near (M/2)^p instead of M^p and avoids most of the cancellation.

The recurrence does not forget its rounding errors: an error in Y_q acts like a phantom
sample that keeps sliding out of the window, and its weight in F_hat grows like a power of
its age (the 4th for U_4). So every M samples the moments are recomputed exactly from the
raw samples, kept in a ring buffer: O(M) once every M samples, O(1) amortised, and the
drift stays a few M ulps of the summed terms. The resync also recovers from a non-finite
sample, which poisons the running sums (inf - inf) until the first resync after it has
left the window (at most 2M samples, against M + 1 for a direct sum). Where a bound on
every step matters more than the mean (the C export, in a control interrupt),
:func:`push_spread` does the resync's work a sample at a time, with the same bits.

n = 1 reads only ``Y_1`` and ``U_0``, ``U_2``; a slide of ``S_p`` reads the moments below
p only, so n = 1 carries ``Y_0, Y_1`` and ``U_0 .. U_2`` alone (:func:`moments_of`) and
leaves the others at zero: the moments it carries get the bits they would get beside all
of them, and its work drops by a third (a block's push, resync and sums at M = 10, one
core: 14.0 against 9.1 ns per member-sample).

State rows (``CS[base + row, j]``)
----------------------------------
``COUNT`` samples pushed since reset (wrapped by M (M + 1) past the first M + 1);
``Y_MOM + N_YMOM * parity + p`` and ``U_MOM + N_UMOM * parity + p`` the moments over
samples of that index parity; ``RING`` then M + 1 rows of y history and M + 1 rows of u
history. Sample m lives in slot m % (M + 1): y_m, and the u pushed with it, u_{m-1}. The
estimator has no parameter rows of its own: the law embedding it passes M, h, alpha and n,
and for the delay-reduced kernel its parameter array and the first of the
:data:`N_JACOBI` rows holding :func:`jacobi_rows`.
"""

import numpy as np

from .._jit import step_jit
from . import variational_gain

# state rows, relative to the caller's base row
COUNT = 0  # samples pushed since reset (wrapped, see push); the newest is k = COUNT - 1
N_YMOM = 3  # y moments p = 0..2
N_UMOM = 5  # u moments p = 0..4
Y_MOM = 1
U_MOM = Y_MOM + 2 * N_YMOM
RING = U_MOM + 2 * N_UMOM  # y ring (M + 1 rows), then u ring (M + 1 rows)

ORDERS = (1, 2)
# the discretisation of the integral (see the module's docstring)
TRAPEZOID = 0.0
HELD = 1.0
DELAY_REDUCED = 2.0  # n = 1: the held relations' weighted line, at lag samples back
KERNELS = {"trapezoid": TRAPEZOID, "held": HELD, "delay-reduced": DELAY_REDUCED}


def kernel_name(value: float) -> str:
    """The name of a kernel as a parameter row stores it (:data:`KERNELS`)."""
    return {v: k for k, v in KERNELS.items()}[float(value)]
#: longest window: its ring buffer of 2 (M + 1) samples stays under 160 MB
MAX_WINDOW = 10_000_000


def n_state(M: int) -> int:
    """CS rows the estimator needs for a window of M samples."""
    return RING + 2 * (M + 1)


#: what :func:`parity_problem` refuses, in words (the caller names the window's key)
EVEN_FOR_SIMPSON = "must be even for order 2 with the trapezoid kernel (Simpson's rule)"


def parity_problem(order: int, M: int, kernel: str) -> bool:
    """Whether window M cannot take (order, kernel): Simpson's rule (order 2, trapezoid
    kernel) needs an even number of intervals. The one statement of the rule: the live
    controllers and the configuration refuse it in their own key's name
    (:data:`EVEN_FOR_SIMPSON`)."""
    return order == 2 and M % 2 == 1 and kernel == "trapezoid"


#: the largest kappa + mu: the delay-reduced kernel's u weights are of degree kappa + mu
#: + 1 and its y weights of kappa + mu, within the moments the window carries (U_3, Y_2)
MAX_JACOBI = 2


def _whole(value) -> bool:
    return bool(isinstance(value, int | np.integer) and not isinstance(value, bool)
                and value >= 0)


def kernel_problem(order: int, M: int, kernel: str, lag: float | None,
                   kappa: int | None = None, mu: int | None = None
                   ) -> tuple[str, str] | None:
    """What the delay-reduced kernel and its ``lag``, ``kappa`` and ``mu`` cannot take,
    as (the parameter at fault, "kernel", "lag", "kappa" or "mu", what is allowed), or
    None: the kernel is of model order 1; kappa and mu (None: 1) are whole numbers >= 0
    with kappa + mu <= 2 (:data:`MAX_JACOBI`: the moments the window carries); lag
    (samples back from the newest) runs from 0 to M, any point of the window; the other
    kernels have none of the three. The one statement of these rules: the live
    controllers and the configuration refuse them in their own keys' names."""
    if kernel == "delay-reduced":
        if order != 1:
            return "kernel", "the delay-reduced kernel is of model order 1: use held"
        weights = {"kappa": 1 if kappa is None else kappa, "mu": 1 if mu is None else mu}
        for key, value in weights.items():
            if not _whole(value):
                return key, (f"must be a whole number from 0 to {MAX_JACOBI} (a Jacobi "
                             "weight's exponent)")
        if weights["kappa"] + weights["mu"] > MAX_JACOBI:
            # the larger exponent is at fault (mu on a tie): a config always gives both
            key = "kappa" if weights["kappa"] > weights["mu"] else "mu"
            return key, (f"kappa + mu must be at most {MAX_JACOBI} (here kappa = "
                         f"{weights['kappa']}, mu = {weights['mu']}): the window's moments "
                         "slide the kernel in O(1) only up to that degree")
        if lag is None or not 0.0 <= lag <= M:
            return "lag", f"must be from 0 to M = {M:g} samples (a point of the window)"
        return None
    for key, given in (("lag", lag), ("kappa", kappa), ("mu", mu)):
        if given is not None:
            return key, (f"only the delay-reduced kernel has a {key}: set the kernel to "
                         "delay-reduced, or remove it")
    return None


#: the delay-reduced kernel's coefficients (:func:`jacobi_rows`), parameter rows of the
#: law embedding the estimator: those of Y_0 .. Y_2, of U_0 .. U_3, of y_{k-M} and of y_k,
#: from row JACOBI on. The law places them right after the gain adaptation's rows, so
#: that a step reads each at a constant row (the C export names every parameter it
#: reads by its row)
JACOBI = variational_gain.N_PARAMS
J_Y0 = JACOBI + 0
J_Y1 = JACOBI + 1
J_Y2 = JACOBI + 2
J_U0 = JACOBI + 3
J_U1 = JACOBI + 4
J_U2 = JACOBI + 5
J_U3 = JACOBI + 6
J_OLD = JACOBI + 7
J_NEW = JACOBI + 8
N_JACOBI = 9


def _times(a: list, b: list) -> list:
    """The product of two polynomials (coefficients in ascending powers)."""
    out = [0 * a[0]] * (len(a) + len(b) - 1)
    for i, x in enumerate(a):
        for k, z in enumerate(b):
            out[i + k] += x * z
    return out


def _at(p: list, x):
    """Polynomial p at x (Horner)."""
    out = 0 * x
    for c in reversed(p):
        out = out * x + c
    return out


def _shifted(p: list, s) -> list:
    """The coefficients of q(c) = p(c + s)."""
    out = [0 * s] * len(p)
    power = [1 + 0 * s]  # (c + s)^i, ascending
    for i, c in enumerate(p):
        if i:
            power = _times(power, [s, 1])
        for k, z in enumerate(power):
            out[k] += c * z
    return out


def jacobi_rows(M: int, kappa: int, mu: int, lag: float) -> np.ndarray:
    """The delay-reduced kernel's :data:`N_JACOBI` coefficients for window M, Jacobi
    weight (kappa, mu) and lag: the one place the kernel's formula is written for the law
    (:func:`weights` writes it again from its definition, as the check).

    The relation phi_j at centred position x_j = j + 1/2 - M/2 (x = +M/2 the newest end)
    weighs ``V(x_j) = w(x_j) [1/W + (x* - xbar)(x_j - xbar)/S]``, the w-weighted
    least-squares line through the phi_j read at x* = M/2 - lag, with
    ``w(x) = (M/2 - x)^kappa (M/2 + x)^mu``, W = sum w, xbar = sum w x / W and
    S = sum w (x - xbar)^2 over the M relations (sums of powers of x to the 4th, in
    closed form). Then F_hat = sy / h - alpha su with ``su = sum_p a_p U_p`` (u_j at its
    centred index c = j - M/2 weighs V(c + 1/2)) and ``sy = sum_p b_p Y_p + e_old y_{k-M}
    + e_new y_k`` (y at c weighs D(c) = V(c - 1/2) - V(c + 1/2), of one degree less, and
    the ends lack the relation one sample past them: e_old = -V(-(M + 1)/2), e_new =
    V((M + 1)/2)). Computed in exact rationals, each coefficient rounded once. Call it
    where parameters are built (:func:`check_window`'s rules hold)."""
    from fractions import Fraction

    m = Fraction(M)
    half = m / 2
    w = [Fraction(1)]
    for _ in range(kappa):
        w = _times(w, [half, Fraction(-1)])
    for _ in range(mu):
        w = _times(w, [half, Fraction(1)])
    # sum over the relations' centres of x^p, p = 0 .. 4 (the odd ones vanish)
    powers = [m, 0, m * (m * m - 1) / 12, 0, m * (m * m - 1) * (3 * m * m - 7) / 240]

    def total(p: list) -> Fraction:
        return sum((c * powers[i] for i, c in enumerate(p)), Fraction(0))

    W = total(w)
    xbar = total(_times(w, [0, 1])) / W
    S = total(_times(w, [xbar * xbar, -2 * xbar, Fraction(1)]))
    tilt = (half - Fraction(lag) - xbar) / S
    V = _times(w, [1 / W - tilt * xbar, tilt])
    a = _shifted(V, Fraction(1, 2))
    b = [p - q for p, q in zip(_shifted(V, Fraction(-1, 2)), a, strict=True)]
    assert not any(b[N_YMOM:]) and len(a) <= J_OLD - J_U0
    rows = [Fraction(0)] * N_JACOBI  # rows JACOBI .. JACOBI + N_JACOBI - 1
    y, u = J_Y0 - JACOBI, J_U0 - JACOBI
    rows[y:y + min(len(b), N_YMOM)] = b[:N_YMOM]
    rows[u:u + len(a)] = a
    rows[J_OLD - JACOBI] = -_at(V, -(m + 1) / 2)
    rows[J_NEW - JACOBI] = _at(V, (m + 1) / 2)
    return np.array([float(r) for r in rows])


@step_jit
def moment_order(order, kernel):
    """The moment set a window of model order ``order`` and ``kernel`` carries, as the
    model order whose set it is (:func:`moments_of`): the delay-reduced kernel's weights
    are one degree up from the held kernel's (y moments to Y_2, u moments to U_3), within
    order 2's set."""
    return 2.0 if kernel == DELAY_REDUCED else order


def check_window(order: int, M: int, kernel: str = "held", lag: float | None = None,
                 kappa: int | None = None, mu: int | None = None) -> None:
    """Raise ValueError unless (order, M, kernel, lag, kappa, mu) is a valid estimator:
    n = 1 or 2, M >= 2, even for n = 2 with the trapezoid kernel (Simpson's rule), the
    delay-reduced kernel of order 1 with 0 <= lag <= M and whole kappa, mu >= 0 with
    kappa + mu <= 2 (:func:`kernel_problem`).

    Call it where parameters are built: the compiled functions cannot raise and return NaN
    for an invalid pair instead.
    """
    if order not in ORDERS:
        raise ValueError(f"order = {order!r}: the ultra-local model order must be 1 or 2")
    if not isinstance(M, int | np.integer) or isinstance(M, bool) or M < 2:
        raise ValueError(f"M = {M!r}: the window must be a whole number of samples >= 2")
    if kernel not in KERNELS:
        raise ValueError(f"kernel = {kernel!r}: must be one of {', '.join(KERNELS)}")
    if parity_problem(order, M, kernel):
        raise ValueError(f"M = {M!r}: {EVEN_FOR_SIMPSON}")
    problem = kernel_problem(order, M, kernel, lag, kappa, mu)
    if problem:
        key, allowed = problem
        value = {"kernel": kernel, "lag": lag, "kappa": kappa, "mu": mu}[key]
        raise ValueError(f"{key} = {value!r}: {allowed}")


@step_jit
def _add(CS, j, row, n_mom, c, v):
    """Moments rows row..row+n_mom-1 += v c^p."""
    t = v
    for p in range(n_mom):
        CS[row + p, j] += t
        t *= c


@step_jit
def _slide(CS, j, row, n_mom):
    """Re-centre moments at c - 1: S_p <- sum_q C(p, q) (-1)^(p-q) S_q (Pascal's triangle)."""
    for i in range(n_mom - 1):
        for p in range(n_mom - 1, i, -1):
            CS[row + p, j] -= CS[row + p - 1, j]


@step_jit
def moments_of(order):
    """How many y and u moments (p = 0 .. count - 1) model order n carries: those its
    sums read and those their slides read (n = 1: Y_0, Y_1 and U_0 .. U_2; n = 2: all)."""
    if order == 1:
        return 2, 3
    return N_YMOM, N_UMOM


@step_jit
def _clear(CS, j, base):
    """Member j's moments set to zero."""
    for row in range(Y_MOM, RING):
        CS[base + row, j] = 0.0


@step_jit
def _sample_rows(base, M, k, m):
    """Where sample m of the ring goes in the moments of the window that ends at sample
    k: (its ring slot, its centred index c, its y moment rows, its u moment rows,
    whether its u is in the u window)."""
    c = m - k + 0.5 * M
    return (m % (M + 1), c, base + Y_MOM + N_YMOM * (m % 2),
            base + U_MOM + N_UMOM * ((m + 1) % 2), m - 1 >= k - M)


@step_jit
def _add_sample_at(CS, j, base, M, slot, c, y_rows, u_rows, with_u, n_y, n_u):
    """:func:`_add_sample` with the rows of :func:`_sample_rows` given, n_y and n_u
    moments of each (:func:`moments_of`)."""
    _add(CS, j, y_rows, n_y, c, CS[base + RING + slot, j])
    if with_u:
        _add(CS, j, u_rows, n_u, c - 1.0, CS[base + RING + M + 1 + slot, j])


@step_jit
def _add_sample(CS, j, base, M, k, m, n_y, n_u):
    """Sample m of the ring added to member j's moments of the window that ends at sample
    k: y_m, and u_{m-1} (stored with y_m) when it is in the u window."""
    slot, c, y_rows, u_rows, with_u = _sample_rows(base, M, k, m)
    _add_sample_at(CS, j, base, M, slot, c, y_rows, u_rows, with_u, n_y, n_u)


@step_jit
def resync(CS, j, base, M, order):
    """Recompute every moment model order ``order`` carries of member j from the ring
    buffer (O(M)); push calls it every M samples."""
    n_y, n_u = moments_of(order)
    _clear(CS, j, base)
    k = int(CS[base + COUNT, j]) - 1  # newest sample
    for m in range(max(0, k - M), k + 1):  # oldest first, as the direct sum
        _add_sample(CS, j, base, M, k, m, n_y, n_u)


@step_jit
def _resync_lanes(CS, j0, j1, base, M, n_y, n_u):
    """:func:`resync_members` with n_y and n_u given: pass literals, so that the loops
    over the moments unroll inside the loop over the members."""
    for j in range(j0, j1):
        _clear(CS, j, base)
    k = int(CS[base + COUNT, j0]) - 1
    for m in range(max(0, k - M), k + 1):
        # the rows once per sample, not per member: a modulus per member is an integer
        # division in a loop that then does not vectorise (measured: a fifth of a
        # bench-lag3 sweep's time at M = 10)
        slot, c, y_rows, u_rows, with_u = _sample_rows(base, M, k, m)
        if with_u:
            for j in range(j0, j1):
                _add_sample_at(CS, j, base, M, slot, c, y_rows, u_rows, True, n_y, n_u)
        else:
            for j in range(j0, j1):
                _add_sample_at(CS, j, base, M, slot, c, y_rows, u_rows, False, n_y, n_u)


@step_jit
def resync_members(CS, j0, j1, base, M, order):
    """:func:`resync` of members j0 .. j1-1, all at the same count and model order: the
    same sums in the same order for each member, with the members the innermost loop, so
    that over a block of them it vectorises (measured: most of the estimator's time in a
    sweep, scalar)."""
    # the moments the order carries, constants in each branch
    if order == 1:
        n_y, n_u = moments_of(1)
        _resync_lanes(CS, j0, j1, base, M, n_y, n_u)
    else:
        n_y, n_u = moments_of(2)
        _resync_lanes(CS, j0, j1, base, M, n_y, n_u)


@step_jit
def reset(CS, j, base, M):
    """Empty the window (all rows, ring included, to zero: missing samples count as 0)."""
    for row in range(RING + 2 * (M + 1)):  # n_state(M)
        CS[base + row, j] = 0.0


@step_jit
def slots(n, M):
    """Where sample n goes in the ring (``n % (M + 1)``) and the slot after it, whose u
    leaves the window with it."""
    m1 = M + 1
    slot = n % m1
    # the next slot without a second division (a run-time modulus is an integer division,
    # tens of cycles; this law runs it at every sample)
    after = slot + 1 if slot + 1 < m1 else 0
    return slot, after


@step_jit
def moments_push(CS, j, base, half, par_in, par_out, y_out, u_out, y, u_prev, n_y, n_u):
    """The moments' part of :func:`push` for sample n (``half`` = M / 2): slid, the
    leaving samples y_out, u_out (of index parity ``par_out``, that of n - M - 1) out,
    the entering ones in (y_n of parity ``par_in`` = n % 2, u_{n-1} of the other); n_y
    and n_u moments of each (:func:`moments_of`). Apart from the ring, so that a loop
    over members at the same sample, given the parities and the counts as constants,
    finds every moment row at a constant distance and vectorises."""
    for par in range(2):
        _slide(CS, j, base + Y_MOM + N_YMOM * par, n_y)
        _slide(CS, j, base + U_MOM + N_UMOM * par, n_u)
    _add(CS, j, base + Y_MOM + N_YMOM * par_out, n_y, -half - 1.0, -y_out)
    _add(CS, j, base + U_MOM + N_UMOM * par_out, n_u, -half - 1.0, -u_out)
    _add(CS, j, base + Y_MOM + N_YMOM * par_in, n_y, half, y)
    _add(CS, j, base + U_MOM + N_UMOM * (1 - par_in), n_u, half - 1.0, u_prev)


@step_jit
def push_at(CS, j, base, M, n, slot, after, y, u_prev, order):
    """The arithmetic of :func:`push` for sample n, its slots given (:func:`slots`): the
    leaving samples read from the ring, the moments updated (:func:`moments_push`), the
    entering samples written to the ring."""
    m1 = M + 1
    # leaving: y_{n-M-1} in the slot about to be overwritten, u_{n-M-1} in the next slot
    # (stored with y_{n-M}); before the window has filled these read the zeros of reset
    y_out = CS[base + RING + slot, j]
    u_out = CS[base + RING + m1 + after, j]
    # (n + M + 1) % 2: the parity of n - M - 1, kept non-negative
    n_y, n_u = moments_of(order)
    moments_push(CS, j, base, 0.5 * M, n % 2, (n + M + 1) % 2, y_out, u_out, y, u_prev,
                 n_y, n_u)
    CS[base + RING + slot, j] = y
    CS[base + RING + m1 + slot, j] = u_prev


@step_jit
def counted(n, M):
    """The count once sample n is pushed."""
    count = n + 1
    # Every reader takes the count modulo M + 1, M or 2 (all divide M (M + 1)) or asks
    # whether the window has filled; so once past full it wraps by M (M + 1) without
    # changing anything, and stays exact in a float32 (M <= 4095) and a 32-bit C integer
    # (M <= 46339) however long the controller runs (:mod:`mfcontrol.cexport`)
    if count >= M + 1 + M * (M + 1):
        count -= M * (M + 1)
    return count


@step_jit
def resync_due(n, M):
    """Whether the moments are recomputed once sample n is pushed: every M samples."""
    return (n + 1) % M == 0


@step_jit
def count_pushed(CS, j, base, M, n, order):
    """Sample n pushed: the count moves on, and every M samples the moments are
    recomputed (O(M))."""
    CS[base + COUNT, j] = counted(n, M)
    if resync_due(n, M):
        resync(CS, j, base, M, order)


@step_jit
def push(CS, j, base, M, y, u_prev, order):
    """Add the newest sample: y_k and the control u_{k-1} applied since the previous one,
    to the moments model order ``order`` (1 or 2) reads.

    O(1) except on every M-th sample, where the moments are recomputed (O(M)).
    """
    n = int(CS[base + COUNT, j])  # index of the entering sample
    slot, after = slots(n, M)
    push_at(CS, j, base, M, n, slot, after, y, u_prev, order)
    count_pushed(CS, j, base, M, n, order)


#: rows after the ring that :func:`push_spread` keeps: the next resync's moments
SPREAD_ROWS = RING - Y_MOM


def n_state_spread(M: int) -> int:
    """CS rows the estimator needs for a window of M samples under :func:`push_spread`."""
    return n_state(M) + SPREAD_ROWS


@step_jit
def push_spread(CS, j, base, M, y, u_prev, order):
    """:func:`push` with the resync spread over the samples: the same bits in every row
    :func:`push` writes, and no O(M) step.

    The resync at sample k sums the window's samples k - M .. k, oldest first, each at its
    centred position c = m - k + M/2, which is known as soon as sample m arrives (the
    resyncs fall on the samples k with (k + 1) % M == 0). So each sample is added, as it
    is pushed, to a second set of moments kept after the ring (:data:`SPREAD_ROWS` rows
    from ``base + n_state(M)``), with the resync's arithmetic and in its order; at the
    resync those rows are what the resync would compute, and are copied in. The sample of
    a resync is also the oldest of the next resync's window (its y only: its u is older
    than that window). Every push then costs about the same: the C export uses this form,
    where a control interrupt needs a bound on its step, not a mean
    (``tests/laws/test_estimators.py`` checks the bits against :func:`push`).
    """
    n = int(CS[base + COUNT, j])  # index of the entering sample
    slot, after = slots(n, M)
    push_at(CS, j, base, M, n, slot, after, y, u_prev, order)
    n_y, n_u = moments_of(order)
    # after the ring (n_state(M) rows), its moment rows at the moments' offsets
    spread = base + RING + 2 * (M + 1) - Y_MOM
    if n == 0:  # a reset window: the next resync's sums start empty
        _clear(CS, j, spread)
    # the next resync is at sample n + M - 1 - n % M
    _, c, y_rows, u_rows, with_u = _sample_rows(spread, M, n + (M - 1 - n % M), n)
    _add(CS, j, y_rows, n_y, c, y)
    if with_u:
        _add(CS, j, u_rows, n_u, c - 1.0, u_prev)
    CS[base + COUNT, j] = counted(n, M)
    if resync_due(n, M):
        for row in range(Y_MOM, RING):
            CS[base + row, j] = CS[spread + row, j]
        _clear(CS, j, spread)
        _, c, y_rows, u_rows, with_u = _sample_rows(spread, M, n + M, n)
        _add(CS, j, y_rows, n_y, c, y)


@step_jit
def window(CS, j, base, M):
    """Where the window ending at the newest sample lies in the ring: (full, oldest slot,
    newest slot, parity of the newest sample's index); ``full`` False until M + 1 samples
    have been pushed (or for M < 2)."""
    n = int(CS[base + COUNT, j])
    k = n - 1
    m1 = M + 1
    newest = k % m1 if n > 0 else 0
    oldest = newest + 1 if newest + 1 < m1 else 0  # n % m1, without a second division
    return n > M and M >= 2, oldest, newest, k % 2 if n > 0 else 0


@step_jit
def _both(CS, j, row, n_mom, p):
    """Moment p over both index parities (rows from ``row``, n_mom of each parity): the
    kernels without Simpson's pattern read these."""
    return CS[row + p, j] + CS[row + n_mom + p, j]


@step_jit
def sums_at(CS, j, base, M, order, oldest, newest, parity, kernel, CP):
    """The window's weighted sums (sy, su) of y and u, the slots given (:func:`window`):
    F_hat = :func:`combine` (sy, su, ...). ``CP[JACOBI .., j]``: the delay-reduced
    kernel's coefficients (:func:`jacobi_rows`; read by it alone). NaN for an invalid
    (order, M, kernel)."""
    y_old = CS[base + RING + oldest, j]  # y_{k-M}
    y_new = CS[base + RING + newest, j]
    fm = float(M)
    half = 0.5 * fm
    h2 = half * half
    y0 = base + Y_MOM
    u0 = base + U_MOM
    if kernel == DELAY_REDUCED and order == 1:
        # the moments times the coefficients of the member's (kappa, mu, lag), the ends
        # corrected (jacobi_rows)
        # (each row written out: a row computed in a loop is not one the C export names)
        sy = (CP[J_OLD, j] * y_old + CP[J_NEW, j] * y_new
              + CP[J_Y0, j] * _both(CS, j, y0, N_YMOM, 0)
              + CP[J_Y1, j] * _both(CS, j, y0, N_YMOM, 1)
              + CP[J_Y2, j] * _both(CS, j, y0, N_YMOM, 2))
        su = (CP[J_U0, j] * _both(CS, j, u0, N_UMOM, 0)
              + CP[J_U1, j] * _both(CS, j, u0, N_UMOM, 1)
              + CP[J_U2, j] * _both(CS, j, u0, N_UMOM, 2)
              + CP[J_U3, j] * _both(CS, j, u0, N_UMOM, 3))
        return sy, su
    if kernel == HELD:
        if order == 1:
            # y weight 2c inside; at the ends -v_0 (y_{k-M}) and +v_{M-1} (y_k), both
            # M/2 - 1/4 in size; u weight v_j ~ M^2/4 - (c + 1/2)^2
            return (2.0 * _both(CS, j, y0, N_YMOM, 1) + (half + 0.25) * (y_old - y_new),
                    (h2 - 0.25) * _both(CS, j, u0, N_UMOM, 0) - _both(CS, j, u0, N_UMOM, 1)
                    - _both(CS, j, u0, N_UMOM, 2))
        if order == 2:
            # y weight: the second difference of g(c) = (h2 - c^2)^2, 12 c^2 + 2 - 4 h2,
            # less g's polynomial value (M + 1)^2 one sample past each end, where the
            # weights are zero; u weight g(c) + g(c + 1)
            m1 = fm + 1.0
            sy = (12.0 * _both(CS, j, y0, N_YMOM, 2) + (2.0 - 4.0 * h2)
                  * _both(CS, j, y0, N_YMOM, 0) - m1 * m1 * (y_old + y_new))
            su = (2.0 * _both(CS, j, u0, N_UMOM, 4) + 4.0 * _both(CS, j, u0, N_UMOM, 3)
                  + (6.0 - 4.0 * h2) * _both(CS, j, u0, N_UMOM, 2)
                  + (4.0 - 4.0 * h2) * _both(CS, j, u0, N_UMOM, 1)
                  + (1.0 - 2.0 * h2 + 2.0 * h2 * h2) * _both(CS, j, u0, N_UMOM, 0))
            return sy, su
        return np.nan, np.nan
    if order == 1:
        # trapezoid: y weight -2c, ends halved (c = -M/2 and +M/2)
        return (2.0 * _both(CS, j, y0, N_YMOM, 1) + half * (y_old - y_new),
                h2 * _both(CS, j, u0, N_UMOM, 0) - _both(CS, j, u0, N_UMOM, 2))
    if order == 2 and M % 2 == 0:
        e = parity  # absolute parity of the even window positions (M even)
        o = 1 - e
        ye = y0 + N_YMOM * e
        yo = y0 + N_YMOM * o
        ue = u0 + N_UMOM * e
        uo = u0 + N_UMOM * o
        gy_e = 6.0 * CS[ye + 2, j] - 2.0 * h2 * CS[ye, j]
        gy_o = 6.0 * CS[yo + 2, j] - 2.0 * h2 * CS[yo, j]
        gu_e = h2 * h2 * CS[ue, j] - 2.0 * h2 * CS[ue + 2, j] + CS[ue + 4, j]
        gu_o = h2 * h2 * CS[uo, j] - 2.0 * h2 * CS[uo + 2, j] + CS[uo + 4, j]
        # Simpson 1-4-2-...-4-1: 2 everywhere, 4 at odd positions, 1 at the ends where the
        # y weight is M^2 and the u weight 0
        return 2.0 * gy_e + 4.0 * gy_o - fm * fm * (y_old + y_new), 2.0 * gu_e + 4.0 * gu_o
    return np.nan, np.nan


@step_jit
def sums(CS, j, base, M, order, kernel, CP):
    """(sy, su) of the window ending at the newest sample; NaN until it is full. CP: the
    law's parameters, the delay-reduced kernel's coefficients among them
    (:func:`sums_at`)."""
    full, oldest, newest, parity = window(CS, j, base, M)
    if not full:
        return np.nan, np.nan
    return sums_at(CS, j, base, M, order, oldest, newest, parity, kernel, CP)


@step_jit
def coefficients(M, h, alpha, order, kernel):
    """(c_y, c_u) with F_hat = c_y sy - c_u su (:func:`combine`): constants of a member
    whose alpha is, which a loop over members computes once, not at every sample (each
    is a division). M, the order and the kernel are whole numbers, as integers or floats:
    the weights' normalisations (the integral of w, or the sum of the held kernel's
    v_j: M (2 M^2 + 1) / 12 for n = 1, M (M^4 - 1) / 30 for n = 2; the delay-reduced
    kernel's coefficients are normalised already, :func:`jacobi_rows`)."""
    fm = float(M)
    if kernel == DELAY_REDUCED:
        return 1.0 / h, alpha
    if kernel == HELD:  # sum v_j
        if order == 1:
            s1 = fm * (2.0 * fm * fm + 1.0)
            return 12.0 / (h * s1), 12.0 * alpha / s1
        s2 = fm * (fm * fm * fm * fm - 1.0)
        return 30.0 / (s2 * h * h), 15.0 * alpha / s2
    if order == 1:
        m3 = fm * fm * fm
        return 6.0 / (h * m3), 6.0 * alpha / m3
    m5 = fm * fm * fm * fm * fm
    return 20.0 / (m5 * h * h), 10.0 * alpha / m5


@step_jit
def combine(sy, su, M, h, alpha, order, kernel):
    """F_hat from the window's sums (:func:`sums`): apart from them because alpha may
    change at every sample (the variational gain) and the sums do not depend on it. M,
    the order and the kernel are whole numbers, as integers or floats."""
    c_y, c_u = coefficients(M, h, alpha, order, kernel)
    return combine_with(sy, su, c_y, c_u)


@step_jit
def combine_with(sy, su, c_y, c_u):
    """:func:`combine` with the member's :func:`coefficients` given."""
    return c_y * sy - c_u * su


@step_jit
def estimate(CS, j, base, M, h, alpha, order, kernel, CP):
    """F_hat for the window ending at the newest sample; it belongs to t_k - M h / 2
    (t_k - lag h with the delay-reduced kernel, whose coefficients are
    ``CP[JACOBI:JACOBI + N_JACOBI, j]``, :func:`jacobi_rows`).

    NaN until the window is full (fewer than M + 1 samples) and for an invalid
    (order, M, kernel).
    """
    sy, su = sums(CS, j, base, M, order, kernel, CP)
    return combine(sy, su, M, h, alpha, order, kernel)


def weights(order: int, M: int, h: float, alpha: float, kernel: str = "held",
            lag: float | None = None, kappa: int | None = None, mu: int | None = None
            ) -> tuple[np.ndarray, np.ndarray]:
    """The estimator as FIR kernels, straight from their definitions (no moments);
    ``lag`` (samples), ``kappa`` and ``mu`` (None: 1) for the delay-reduced kernel.

    Returns ``(wy, wu)``, oldest sample first, of lengths M + 1 and M, such that
    ``F_hat = wy @ [y_{k-M}, ..., y_k] + wu @ [u_{k-M}, ..., u_{k-1}]``.

    Examples
    --------
    The held kernel is exact under a held input: y' = 3 + 2 u with u = +-1 at random.

    >>> import numpy as np
    >>> from mfcontrol.laws import estimators
    >>> h, M = 0.01, 4
    >>> u = np.random.default_rng(0).choice([-1.0, 1.0], M)
    >>> y = np.concatenate([[0.0], np.cumsum(h * (3.0 + 2.0 * u))])
    >>> wy, wu = estimators.weights(1, M, h, 2.0, "held")
    >>> round(float(wy @ y + wu @ u), 12)
    3.0
    """
    check_window(order, M, kernel, lag, kappa, mu)
    T = M * h
    i = np.arange(M + 1)
    s = h * i
    if kernel == "delay-reduced":
        # the held relations' w-weighted least-squares line, read at lag samples back:
        # the relations' centres x_j (centred sample units, +M/2 the newest end)
        x = np.arange(M) + 0.5 - 0.5 * M
        w = (0.5 * M - x) ** (1 if kappa is None else kappa) * (0.5 * M + x) ** (
            1 if mu is None else mu)
        xbar = (w * x).sum() / w.sum()
        tilt = (0.5 * M - float(lag or 0.0) - xbar) / (w * (x - xbar) ** 2).sum()
        v = w * (1.0 / w.sum() + tilt * (x - xbar))
        wy = (np.concatenate([[0.0], v]) - np.concatenate([v, [0.0]])) / h
        return wy, -alpha * v
    if kernel == "held":
        # v_j, the weights of the exact relations (the module's docstring), then the y
        # and u weights they give
        if order == 1:
            mid = s[:M] + 0.5 * h
            v = mid * (T - mid)
            v /= v.sum()
            wy = (np.concatenate([[0.0], v]) - np.concatenate([v, [0.0]])) / h
            return wy, -alpha * v
        centre = s[1:M]
        v = centre**2 * (T - centre) ** 2
        v /= v.sum()
        padded = np.concatenate([[0.0, 0.0], v, [0.0, 0.0]])
        wy = (padded[:-2] - 2.0 * padded[1:-1] + padded[2:]) / h**2
        wu = -0.5 * alpha * (padded[1:-2] + padded[2:-1])
        return wy[: M + 1], wu[:M]
    if order == 1:
        q = np.full(M + 1, h)  # trapezoid
        q[0] = q[-1] = 0.5 * h
        wy = -(6.0 / T**3) * q * (T - 2.0 * s)
        wu = -(6.0 / T**3) * q * alpha * s * (T - s)
    else:
        q = np.where(i % 2 == 1, 4.0 * h / 3.0, 2.0 * h / 3.0)  # Simpson
        q[0] = q[-1] = h / 3.0
        wy = (60.0 / T**5) * q * (T**2 - 6.0 * T * s + 6.0 * s**2)
        wu = -(60.0 / T**5) * q * (0.5 * alpha) * s**2 * (T - s) ** 2
    return wy, wu[:M]
