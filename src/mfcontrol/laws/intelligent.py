"""Positional intelligent controllers (Fliess & Join): i-P, i-PI, i-PD, i-PID.

Ultra-local model of order n = 1 or 2, ``y^(n) = F + alpha u``, error ``e = y - y*``::

    u = -(F_hat - y*^(n) + K_P e + K_I int(e) + K_D e') / alpha

i-P has K_I = K_D = 0, i-PI adds the integral, i-PD (n = 2) the derivative, i-PID all
three. ``1/alpha`` is the gain gamma of :mod:`mfcontrol.laws.variational_gain` (constant, the
variational update of the paper driven by the error derivative, supplied by the caller,
or estimated online by recursive least squares: :func:`_rls`).

F_hat, selectable:

* backward difference: ``F_hat_k = y^(n)_k - alpha u_{k-1}`` with ``y'_k = (y_k - y_{k-1})/dt``
  and ``y''_k = (y_k - 2 y_{k-1} + y_{k-2})/dt^2``. With it the i-P is the incremental law
  ``u_k = u_{k-1} - (y^(n)_k - y*^(n)_k + K_P e_k)/alpha``. For n = 1 it is exact under
  a held input. For n = 2 the ``kernel`` decides: ``held`` subtracts
  ``alpha (u_{k-1} + u_{k-2}) / 2``, which a held input makes exact (the second
  difference of y over two held samples is h^2 (F + alpha (u_{k-1} + u_{k-2}) / 2)); the
  i-P on y'' = beta u is then stable for alpha down to about beta/3. ``trapezoid`` keeps
  the literature's ``alpha u_{k-1}``, half a sample out of line, stable only above about
  beta/2.
* algebraic: the integral estimator of :mod:`mfcontrol.laws.estimators` over the last M
  samples (its value belongs to t - M dt / 2), with the same ``kernel`` choice (exact
  under a held input, or the literature's trapezoid / Simpson rule), or for n = 1 the
  ``delay-reduced`` kernel of Jacobi weight (kappa, mu), whose value belongs to
  t - lag dt (exact for F affine in time). Until its window is
  full the ``startup`` decides: ``hold`` holds the output (u_init, or the bumpless start)
  for the first M samples, so the loop first runs on a full window; ``backward-difference``
  lets the backward difference stand in, whose stability bound (alpha > beta (2 + K_P h)
  / 4 for n = 1 on y' = beta u) is much narrower than the full estimator's: it can blow
  up a loop the estimator would hold.

``u_{k-1}`` is the *applied* (limited) output: the ultra-local model relates y to what the
plant received, so the F term never winds up. The integral can; anti-windup, selectable:

* ``clamp``: conditional integration: the integral is frozen on a sample where the output
  is limited and integrating would push it further past the limit;
* ``back-calculation``: the integral is corrected by ``K_aw dt (u - u_unlimited)``,
  expressed in integral units.

Delay: with a known input delay of d samples (the actuator's and the sensor's together)
the estimators pair y with the input the plant received, ``u_{k-1-d}`` (and
``u_{k-2-d}``), not the one just sent; the law keeps its last d + 2 outputs for it
(:func:`in_flight`). With ``predict`` (n = 1) the error is also predicted over the
delay by the ultra-local model, ``y_{k+d} = y_k + h (d F_hat + alpha (u_{k-d} + ... +
u_{k-1}))``: the model-free counterpart of a Smith predictor.

Until n samples have been seen no derivative exists: the output holds ``u_init``
(:func:`held`).
"""

import math

from .._jit import step_jit
from . import estimators, variational_gain
from . import tunable as _tunable

# parameter rows: the gain adaptation's, then the delay-reduced kernel's coefficients of
# the window's moments (estimators.N_JACOBI rows from estimators.JACOBI, from (M, kappa,
# mu, lag) where the parameters are built: estimators.jacobi_rows), then these
JACOBI = estimators.JACOBI
_P0 = estimators.JACOBI + estimators.N_JACOBI
N_ORDER = _P0 + 0  # ultra-local model order n (1 or 2)
KP = _P0 + 1
KI = _P0 + 2
KD = _P0 + 3
EST = _P0 + 4  # 0 backward difference, 1 algebraic
M_WIN = _P0 + 5  # algebraic window, samples
OUT_MIN = _P0 + 6
OUT_MAX = _P0 + 7
AW = _P0 + 8  # 0 none, 1 clamp, 2 back-calculation
K_AW = _P0 + 9
U_INIT = _P0 + 10
KERNEL = _P0 + 11  # estimators.TRAPEZOID, HELD or DELAY_REDUCED
STARTUP = _P0 + 12  # START_BACKWARD or START_HOLD
DELAY = _P0 + 13  # the loop's known input delay d, samples
PREDICT = _P0 + 14  # 1: the error predicted over the delay
LAG = _P0 + 15  # the delay-reduced kernel's lag, samples
# its Jacobi weight's exponents, kept as given (the law reads the coefficients)
KAPPA = _P0 + 16
MU = _P0 + 17
N_PARAMS = _P0 + 18
#: the longest delay a law compensates, samples: a queue of that many outputs per member
#: (0.8 MB each; the loop elements' own delays go to 1,000,000, in a ring per thread)
MAX_DELAY = 100_000


def delay_problem(delay: int, predict: bool, order: int) -> tuple[str, str] | None:
    """What the law cannot run of a compensated delay (a whole number of samples >= 0)
    and a prediction over it: (the option at fault, "delay" or "predict", what is
    allowed, with ``{order}`` where the caller names its order option), or None. The one
    statement of these rules: the live controllers and the configuration refuse them in
    their own keys' names."""
    if delay > MAX_DELAY:
        return "delay", f"must be a whole number of samples from 0 to {MAX_DELAY:,}"
    if predict and order != 1:
        return "predict", ("the prediction over the delay is of order 1: set {order}1, "
                           "or remove it")
    return None

BACKWARD = 0.0
ALGEBRAIC = 1.0
ESTIMATORS = {"backward-difference": BACKWARD, "algebraic": ALGEBRAIC}
AW_NONE = 0.0
AW_CLAMP = 1.0
AW_BACK = 2.0
ANTI_WINDUP = {"none": AW_NONE, "clamp": AW_CLAMP, "back-calculation": AW_BACK}

KERNELS = estimators.KERNELS
START_BACKWARD = 0.0
START_HOLD = 1.0
STARTUPS = {"hold": START_HOLD, "backward-difference": START_BACKWARD}

# state rows (after the gain adaptation rows)
K = variational_gain.N_STATE + 0  # samples taken
Y1 = variational_gain.N_STATE + 1  # y_{k-1}
Y2 = variational_gain.N_STATE + 2  # y_{k-2}
R1 = variational_gain.N_STATE + 3  # r_{k-1}
R2 = variational_gain.N_STATE + 4  # r_{k-2}
U1 = variational_gain.N_STATE + 5  # applied u_{k-1}
INTEG = variational_gain.N_STATE + 6  # integral of e
E1 = variational_gain.N_STATE + 7  # e_{k-1}
# the last sample's terms, for inspection
C_F = variational_gain.N_STATE + 8  # the estimate of F
C_FF = variational_gain.N_STATE + 9  # feed-forward y*^(n)
C_P = variational_gain.N_STATE + 10  # the last sample's proportional term
C_I = variational_gain.N_STATE + 11  # the last sample's integral term
C_D = variational_gain.N_STATE + 12  # the last sample's derivative term
C_UNLIM = variational_gain.N_STATE + 13  # the last sample's output before the limits
U2 = variational_gain.N_STATE + 14  # applied u_{k-2}
# the rls gain's estimate (F / alpha0, alpha / alpha0) and covariance P (11, 12, 22)
RLS_F = variational_gain.N_STATE + 15  # rls: the estimate of F / alpha0
RLS_A = variational_gain.N_STATE + 16  # rls: the estimate of alpha / alpha0
RLS_P11 = variational_gain.N_STATE + 17  # rls: covariance P11
RLS_P12 = variational_gain.N_STATE + 18  # rls: covariance P12
RLS_P22 = variational_gain.N_STATE + 19  # rls: covariance P22
EST_BASE = variational_gain.N_STATE + 20
#: the terms of the bracket by signal name: a live controller's ``components`` and the
#: engine's recorded trajectory rows both read these
COMPONENTS = (("F_hat", C_F), ("feedforward", C_FF), ("P", C_P), ("I", C_I), ("D", C_D))


def tunable(cp) -> tuple[tuple[str, int, str], ...]:
    """The rows a running controller may retune, (field, row, what), of a law with the
    parameter column ``cp`` (:mod:`mfcontrol.laws.tunable`): the gains, the limits, the
    back-calculation's k_aw where it has one, and the gain's own
    (:func:`mfcontrol.laws.variational_gain.tunable`). The order, the estimator, its window
    and kernel, the start-up, the anti-windup's kind and the delay fix its structure."""
    rows = [("kp", KP, "proportional gain K_P"), ("ki", KI, "integral gain K_I"),
            ("kd", KD, "derivative gain K_D")]
    if cp[AW] == AW_BACK:
        rows.append(("k_aw", K_AW, "back-calculation gain (1/s), >= 0"))
    rows += [("out_min", OUT_MIN, "lower output limit (-INFINITY: none)"),
             ("out_max", OUT_MAX, "upper output limit (INFINITY: none), >= out_min")]
    return (*rows, *variational_gain.tunable(cp[variational_gain.MODE]))


def invalid_row(CP, j):
    """The first row of :func:`tunable` whose value the law is not defined for, or -1."""
    if not math.isfinite(CP[KP, j]):
        return KP
    if not math.isfinite(CP[KI, j]):
        return KI
    if not math.isfinite(CP[KD, j]):
        return KD
    if CP[AW, j] == AW_BACK:
        k_aw = CP[K_AW, j]
        if not (math.isfinite(k_aw) and k_aw >= 0.0):
            return K_AW
    if not _tunable.limits_ok(CP[OUT_MIN, j], CP[OUT_MAX, j]):
        return OUT_MAX
    return variational_gain.invalid_row(CP, j)


def n_state(M: int, d: int = 0) -> int:
    """State rows for a window of M samples (M = 0: no algebraic estimator) and a
    compensated delay of d samples (its queue of the last d + 2 outputs after the
    estimator's rows, :func:`queue_base`)."""
    return EST_BASE + (estimators.n_state(M) if M > 0 else 0) + (d + 2 if d > 0 else 0)


@step_jit
def queue_base(CP, j):
    """The first row of the delay's queue of outputs: after the estimator's rows (the
    rows where the C export keeps its spread resync's moments: it refuses a delay)."""
    if CP[EST, j] == ALGEBRAIC:
        return EST_BASE + estimators.RING + 2 * (int(CP[M_WIN, j]) + 1)  # its n_state
    return EST_BASE


@step_jit
def in_flight(CP, CS, j, k, d):
    """With an input delay of d samples (> 0), at sample k: (u_{k-1-d}, u_{k-2-d}), the
    inputs the plant received over the last two samples, which the estimator of F pairs
    with y, and the sum of u_{k-d} .. u_{k-1}, those sent and not yet received. u_m
    lives in slot m % (d + 2) of the queue; before the start every slot holds u_init."""
    base = queue_base(CP, j)
    m = int(d) + 2
    kk = int(k)
    s_u = 0.0
    for i in range(1, int(d) + 1):
        s_u += CS[base + (kk - i + m) % m, j]
    return CS[base + (kk + 1) % m, j], CS[base + kk % m, j], s_u


@step_jit
def _queue(CP, CS, j, k, d, u):
    """u_k into the delay's queue (over u_{k-2-d}, read by :func:`in_flight` before)."""
    CS[queue_base(CP, j) + int(k) % (int(d) + 2), j] = u


@step_jit
def reset(CP, CS, j):
    variational_gain.reset(CP, CS, j)
    for row in range(K, EST_BASE):
        CS[row, j] = 0.0
    CS[U1, j] = CP[U_INIT, j]
    CS[U2, j] = CP[U_INIT, j]
    # rls: the prior, alpha = alpha0 (the regression is normalised by it)
    CS[RLS_A, j] = 1.0
    CS[RLS_P11, j] = variational_gain.RLS_P0_F
    CS[RLS_P22, j] = variational_gain.RLS_P0_ALPHA
    if CP[EST, j] == ALGEBRAIC:
        estimators.reset(CS, j, EST_BASE, int(CP[M_WIN, j]))
    fill_queue(CP, CS, j, CP[U_INIT, j])


@step_jit
def fill_queue(CP, CS, j, u):
    """Every slot of the delay's queue (if any) to u: the output held before the start."""
    d = int(CP[DELAY, j])
    if d > 0:
        base = queue_base(CP, j)
        for i in range(d + 2):
            CS[base + i, j] = u


@step_jit
def _limit(x, lo, hi):
    return hi if x > hi else (lo if x < lo else x)


#: from this sample on the law depends on k only through its state (the model order n is
#: at most 2 and the gain adaptation starts at its own STEADY), once past :func:`held`'s
#: hold: a loop over members may run every later sample through :func:`steady_step`,
#: without the start-up branches
STEADY = max(2.0, variational_gain.STEADY)


@step_jit
def derivatives(n, y, r, y1, y2, r1, r2, dt):
    """(y', y*', y^(n), y*^(n)) by backward differences from the last three samples."""
    yd = (y - y1) / dt
    rd = (r - r1) / dt
    if n == 2.0:
        yn = (y - 2.0 * y1 + y2) / (dt * dt)
        rn = (r - 2.0 * r1 + r2) / (dt * dt)
    else:
        yn = yd
        rn = rd
    return yd, rd, yn, rn


@step_jit
def output(f_hat, rn, gamma, e, integ1, e1, dt, kp, ki, kd, lo, hi, aw, k_aw):
    """The bracket from plain floats: (u_k applied, u unlimited, the integral carried,
    e'_k), with anti-windup; the one place it is written (:func:`step` and
    :func:`steady_step` call it). Every branch is
    arithmetic, so a loop over members turns it into selects."""
    integ = integ1 + e * dt
    e_d = (e - e1) / dt
    base = f_hat - rn + kp * e + kd * e_d
    u_unlim = -gamma * (base + ki * integ)
    u = _limit(u_unlim, lo, hi)
    if ki != 0.0 and u != u_unlim:
        if aw == AW_CLAMP:
            # integrating moved u further past the limit it hit: undo it
            pushed = -gamma * ki * (integ - integ1)
            if (u_unlim > hi and pushed > 0.0) or (u_unlim < lo and pushed < 0.0):
                # integ1 + 0.0, not integ1 (the same but for -0.0, which turns +0.0): a
                # store of the value just loaded would let the compiler skip it, and a
                # loop over members would then store the integral through a mask,
                # microcoded on AMD cores (the i-PI's loop over a block, one core: 17.7
                # against 16.5 ns per member-sample)
                integ = integ1 + 0.0
                u_unlim = -gamma * (base + ki * integ)
                u = _limit(u_unlim, lo, hi)
        elif aw == AW_BACK:
            integ = integ + k_aw * dt * (u - u_unlim) / (-gamma * ki)
    return u, u_unlim, integ, e_d


@step_jit
def held_input(CP, j, n, u1, u2):
    """The input the ultra-local model pairs with y^(n)_k under the held input: u_{k-1}
    (n = 1), or (u_{k-1} + u_{k-2}) / 2 with the held kernel at n = 2 (the second
    difference of y over two held samples); the literature's u_{k-1} with the trapezoid
    kernel. (u1, u2): the inputs the plant received over the last two samples."""
    if n == 2.0 and CP[KERNEL, j] == estimators.HELD:
        return 0.5 * (u1 + u2)
    return u1


@step_jit
def _rls(CP, CS, j, yn, v):
    """The rls gain's step at a sample with y^(n) = yn and held input v: the estimate of
    (F, alpha) moved (:func:`mfcontrol.laws.variational_gain.rls_step`, on the relation
    divided by the starting alpha0), and alpha, clipped, written where the gain reads
    it (``ALPHA_EXT``)."""
    inv0 = CP[variational_gain.INV_ALPHA, j]
    f, a, p11, p12, p22 = variational_gain.rls_step(
        CS[RLS_F, j], CS[RLS_A, j], CS[RLS_P11, j], CS[RLS_P12, j], CS[RLS_P22, j],
        yn * inv0, v, CP[variational_gain.FORGET, j],
        variational_gain.RLS_P0_F + variational_gain.RLS_P0_ALPHA)
    CS[RLS_F, j] = f
    CS[RLS_A, j] = a
    CS[RLS_P11, j] = p11
    CS[RLS_P12, j] = p12
    CS[RLS_P22, j] = p22
    CS[variational_gain.ALPHA_EXT, j] = _limit(a / inv0, CP[variational_gain.ALPHA_LO, j],
                                                CP[variational_gain.ALPHA_HI, j])


@step_jit
def _bracket(CP, CS, j, y, r, dt, k, n, aw, algebraic, sy, su, u1, u2, predict, s_u, d):
    """Sample k >= n past the hold: the derivatives, gamma, F_hat, the bracket and its
    terms into the state; returns (u_k applied, u unlimited, gamma_k). With ``algebraic``,
    (sy, su) are the estimator's window sums (:func:`mfcontrol.laws.estimators.sums`:
    NaN until the window is full, and the backward difference stands in). (u1, u2): the
    inputs the plant received over the last two samples; ``predict``: the error is
    predicted over the delay d, s_u the sum of the inputs sent and not yet received
    (:func:`in_flight`)."""
    yd, rd, yn, rn = derivatives(n, y, r, CS[Y1, j], CS[Y2, j], CS[R1, j], CS[R2, j], dt)
    if CP[variational_gain.MODE, j] == variational_gain.RLS:
        _rls(CP, CS, j, yn, held_input(CP, j, n, u1, u2))
    gamma, _ = variational_gain.update(CP, CS, j, k, yd - rd, dt)
    alpha = 1.0 / gamma
    c_y = 0.0
    c_u = 0.0
    if algebraic:
        # M and n as the floats they are stored as: an int() of them here stops a loop
        # over members from vectorising (measured: the algebraic i-PI's law, scalar)
        c_y, c_u = estimators.coefficients(CP[M_WIN, j], dt, alpha, n, CP[KERNEL, j])
    return _terms(CP, CS, j, y, r, dt, n, aw, algebraic, sy, su, yn, rn, gamma, alpha,
                  c_y, c_u, u1, u2, predict, s_u, d)


@step_jit
def _bracket_fixed(CP, CS, j, y, r, dt, n, aw, algebraic, sy, su, alpha, c_y, c_u):
    """:func:`_bracket` of a member whose gain is constant, with alpha = 1 / gamma and
    the estimator's coefficients given (:func:`fixed_gain`): the same values, without
    their four divisions a sample."""
    _, _, yn, rn = derivatives(n, y, r, CS[Y1, j], CS[Y2, j], CS[R1, j], CS[R2, j], dt)
    gamma, _ = variational_gain.update_constant(CP, CS, j)
    return _terms(CP, CS, j, y, r, dt, n, aw, algebraic, sy, su, yn, rn, gamma, alpha,
                  c_y, c_u, CS[U1, j], CS[U2, j], False, 0.0, 0.0)


@step_jit
def _terms(CP, CS, j, y, r, dt, n, aw, algebraic, sy, su, yn, rn, gamma, alpha, c_y,
           c_u, u1, u2, predict, s_u, d):
    """The bracket of model order n from the sample's derivatives (yn, rn) and gain
    (gamma, alpha = 1 / gamma, the estimator's coefficients c_y, c_u), its terms into the
    state; returns (u_k applied, u unlimited, gamma_k). (u1, u2, predict, s_u, d): as
    :func:`_bracket` takes them."""
    e = y - r
    f_hat = yn - alpha * held_input(CP, j, n, u1, u2)
    if algebraic:
        f_alg = estimators.combine_with(sy, su, c_y, c_u)
        if not math.isnan(f_alg):
            f_hat = f_alg
    if predict:
        # y once the inputs already sent have reached the plant, by the ultra-local model
        # (n = 1): y_{k+d} = y_k + h (d F + alpha (u_{k-d} + ... + u_{k-1}))
        e = e + dt * (d * f_hat + alpha * s_u)
    kp, ki, kd = CP[KP, j], CP[KI, j], CP[KD, j]
    u, u_unlim, integ, e_d = output(f_hat, rn, gamma, e, CS[INTEG, j], CS[E1, j], dt, kp, ki,
                                    kd, CP[OUT_MIN, j], CP[OUT_MAX, j], aw, CP[K_AW, j])
    CS[INTEG, j] = integ
    CS[C_F, j] = f_hat
    CS[C_FF, j] = rn
    CS[C_P, j] = kp * e
    CS[C_I, j] = ki * integ
    CS[C_D, j] = kd * e_d
    CS[C_UNLIM, j] = u_unlim
    CS[E1, j] = e
    return u, u_unlim, gamma


@step_jit
def _remember(CS, j, y, r, u):
    """The sample's y, r and applied u into the history; one more sample seen (the
    error is kept where it is computed, :func:`_terms`, or the start's hold)."""
    CS[Y2, j] = CS[Y1, j]
    CS[Y1, j] = y
    CS[R2, j] = CS[R1, j]
    CS[R1, j] = r
    CS[U2, j] = CS[U1, j]
    CS[U1, j] = u
    CS[K, j] = CS[K, j] + 1.0


@step_jit
def held(CP, j, n, algebraic):
    """How many samples the output holds at the start: n (no derivative exists before),
    or the algebraic estimator's window M with ``startup = hold`` (its window is full
    from sample M on)."""
    if algebraic and CP[STARTUP, j] == START_HOLD:
        return max(n, CP[M_WIN, j])
    return n


@step_jit
def step(CP, CS, j, y, r, dt):
    """One sample: measurement y_k, reference r_k and period dt in; applied u_k out."""
    k = CS[K, j]
    n = CP[N_ORDER, j]
    algebraic = CP[EST, j] == ALGEBRAIC
    d = CP[DELAY, j]
    u1 = CS[U1, j]
    u2 = CS[U2, j]
    s_u = 0.0
    if d > 0.0:
        u1, u2, s_u = in_flight(CP, CS, j, k, d)
    if algebraic:
        estimators.push(CS, j, EST_BASE, int(CP[M_WIN, j]), y, u1,
                        estimators.moment_order(n, CP[KERNEL, j]))
    if k < held(CP, j, n, algebraic):
        u = CS[U1, j]
        CS[C_UNLIM, j] = u
        CS[E1, j] = y - r
    else:
        sy = 0.0
        su = 0.0
        if algebraic:
            sy, su = estimators.sums(CS, j, EST_BASE, int(CP[M_WIN, j]), int(n),
                                     CP[KERNEL, j], CP)
        predict = d > 0.0 and CP[PREDICT, j] != 0.0
        u, _, _ = _bracket(CP, CS, j, y, r, dt, k, n, CP[AW, j], algebraic, sy, su, u1, u2,
                           predict, s_u, d)
    if d > 0.0:
        _queue(CP, CS, j, k, d, u)
    _remember(CS, j, y, r, u)
    return u


@step_jit
def fixed_gain(CP, j, dt, simple):
    """(alpha, c_y, c_u) of a member whose gain is constant, as :func:`steady_step` takes
    them with ``fixed``: computed once for a run, in the law's own expressions."""
    n = 1.0 if simple else CP[N_ORDER, j]
    alpha = 1.0 / CP[variational_gain.INV_ALPHA, j]
    c_y, c_u = estimators.coefficients(CP[M_WIN, j], dt, alpha, n, CP[KERNEL, j])
    return alpha, c_y, c_u


@step_jit
def steady_step(CP, CS, j, y, r, dt, simple, algebraic, sy, su, fixed, alpha, c_y, c_u):
    """:func:`step` for a sample past the start-up (k >= :data:`STEADY` and past
    :func:`held`'s hold) with the
    start-up's branches compiled out, so that a loop over members vectorises; returns
    (u_k applied, u unlimited, gamma_k). ``simple`` (pass a literal True or False: the
    caller compiles one loop for each): the member has model order 1 and no
    back-calculation, which takes the branches of order 2 and of back-calculation, with
    their divisions, out of the loop (measured 9.8 against 6.6 ns per member-sample).
    ``algebraic``: the algebraic estimator, its sample already pushed and its window sums
    (sy, su) taken (:func:`mfcontrol.laws.estimators.push`, ``sums``), which a loop over
    members at the same sample does once for all of them. The member compensates no
    delay (its DELAY is 0). ``fixed`` (a literal): the
    member's gain is constant, and (alpha, c_y, c_u) are its :func:`fixed_gain`."""
    n = 1.0 if simple else CP[N_ORDER, j]
    aw = CP[AW, j]
    if simple:
        aw = AW_CLAMP if aw == AW_CLAMP else AW_NONE
    if fixed:
        u, u_unlim, gamma = _bracket_fixed(CP, CS, j, y, r, dt, n, aw, algebraic, sy, su,
                                           alpha, c_y, c_u)
    else:
        u, u_unlim, gamma = _bracket(CP, CS, j, y, r, dt, STEADY, n, aw, algebraic, sy, su,
                                     CS[U1, j], CS[U2, j], False, 0.0, 0.0)
    _remember(CS, j, y, r, u)
    return u, u_unlim, gamma
