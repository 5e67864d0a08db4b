"""The i-P, i-PI, i-PD and i-PID with the backward-difference estimator as fixed-point C
(``real="q31"``), for a microcontroller without a floating-point unit.

As :mod:`mfcontrol.cexport.fixed_point` does for the PID: the law of
:mod:`mfcontrol.laws.intelligent` written out in integer arithmetic, every coefficient
computed here from the controller's parameters, and held to the double law by tests
(``tests/cexport/test_fixed_point_intelligent.py``: within an error bound derived step by
step on the case's closed loop, with hostile codes, and with the same codes on a
Cortex-M0). The formats are the PID's (:func:`mfcontrol.cexport.fixed_point.scales`).

The law in codes. With the backward difference the estimate of F cancels the input term:
``u = -gamma (y^(n) - alpha u_h - y*^(n) + K_P e + K_I I + K_D e')`` is, exactly in real
arithmetic (``gamma alpha = 1``),

    u = u_h - (gamma / h^n) D^n e - gamma K_P e - gamma K_D (e - e_1) / h - T

with ``e = y - y*`` (y's derivatives minus the setpoint's are the error's), ``D^n e`` its
first (n = 1) or second difference, ``u_h`` the held input of the ultra-local model (the
last applied output, or the mean of the last two with n = 2 and the held kernel), and
``T = gamma K_I I`` the integral term, carried in output units:
``T_k = T_{k-1} + gamma K_I h e``. Back-calculation, ``I += K_aw h (u - v) / (-gamma
K_I)`` in the double law, is ``T -= K_aw h (u - v)``: no division. The clamp undoes the
sample's integration where it pushed the output further past the limit it hit.

Formats. The measurement and the setpoint are the PID's ``int32_t`` codes; the error and
its differences are formed in 64 bits (no saturation: ``|D^2 e| < 2^35``). The output, its
last two values and T are held in 64 bits with :data:`GUARD_BITS` fraction bits beyond
the output's code (the output carries from sample to sample through ``u_h``, so its
rounding does not accumulate in codes); each term is a 64-bit product with a coefficient
``M 2^-S`` split so that nothing overflows, rounded to nearest, and saturated. The code
returned is the output rounded to the output's code. A rejected sample (a measurement
outside the input limits) holds the output, and the next sample taken spans its period as
the double law does: its differences divided by d^n and d, T's increment times d, for
d - 1 rejected samples in a row (up to 255; integer divisions on that step only).

The coefficients and the output limits' codes are a parameter struct that
``PREFIX_set_params`` checks and changes at run time, as the PID's
(:mod:`mfcontrol.cexport.fixed_point`), or constants with ``frozen``. The order, the
kernel and the anti-windup's kind are the code's structure: a set is for an export of the
same structure (its format tag says so).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import ConfigError
from ..laws import estimators, intelligent
from ..laws import variational_gain as gain_law
from .fixed_point import (
    BITS,
    TUNABLE_PARTS,
    Coefficient,
    Scales,
    _format,
    export_scales,
    params_c,
    q31_files,
    tunable_parts,
)

#: the shifts a coefficient of this law may have: a product splits its 64-bit operand into
#: 16-bit halves, so a coefficient up to just under 2^46 (shift -15) still forms without
#: overflow
SHIFTS = (-15, 62)


@dataclass(frozen=True)
class Q31Intelligent:
    """The scales and coefficients of an intelligent controller's q31 export (each
    coefficient in output codes per code of its operand; T's and the output's guard bits
    are applied in the C)."""

    scales: Scales
    order: int
    held_mean: bool  # u_h: the mean of the last two applied outputs (n = 2, held kernel)
    cn: Coefficient  # gamma / h^n, on D^n e
    cp: Coefficient  # gamma K_P, on e
    cd: Coefficient  # gamma K_D / h, on e - e_1
    ci: Coefficient  # gamma K_I h, on e (T's increment)
    caw: Coefficient  # K_aw h, on u - v (back-calculation)
    anti_windup: float  # intelligent.AW_*
    u_init: int  # the output held before the first n samples, a code


def q31_intelligent(ctrl, key_prefix: str = "", like=None) -> Q31Intelligent:
    """The q31 formats of a live intelligent controller (refusing what they cannot hold);
    with ``like``, the controller an export was made from, in that export's formats (its
    structure required the same)."""
    cp = ctrl._CP[:, 0]
    p = key_prefix
    if cp[intelligent.EST] != intelligent.BACKWARD:
        raise ConfigError(f"{p}estimator", "algebraic", "a fixed-point export has the "
                          "backward-difference estimator only: export it in float")
    if cp[gain_law.MODE] != gain_law.CONSTANT:
        raise ConfigError("gain", ctrl._params.get("gain"), "a fixed-point export has "
                          "a constant gain only: export it in float")
    if cp[intelligent.DELAY] > 0:
        raise ConfigError(f"{p}delay", int(cp[intelligent.DELAY]), "the exported step "
                          "compensates no delay yet: export with delay 0")
    sc = export_scales(ctrl, key_prefix, like)
    h = float(ctrl.sample_time)
    n = int(cp[intelligent.N_ORDER])
    gamma = float(cp[gain_law.INV_ALPHA])
    kp, ki, kd = (float(cp[row]) for row in (intelligent.KP, intelligent.KI, intelligent.KD))
    aw = float(cp[intelligent.AW])  # the structure's, whatever ki is now (it may change)
    k_aw = float(cp[intelligent.K_AW]) if aw == intelligent.AW_BACK else 0.0
    if k_aw * h > 1.0:
        raise ConfigError(f"{p}k_aw", k_aw, f"k_aw h = {k_aw * h:.3g} > 1 over-corrects the "
                          "integral at every limited sample: a fixed-point export needs "
                          "k_aw <= 1 / sample_time")
    ratio = sc.y_scale / sc.u_scale  # output codes per measurement code, per unit gain
    alpha = ctrl._params.get("alpha", 1.0 / gamma)  # as the user gave it

    def coefficient(value: float, name: str, given: float) -> Coefficient:
        return Coefficient.of(value, f"{p}{name}", given, SHIFTS)
    u_init = min(max(float(cp[intelligent.U_INIT]), sc.u_lo), sc.u_hi)
    q = Q31Intelligent(
        sc, n, n == 2 and cp[intelligent.KERNEL] == estimators.HELD,
        coefficient(gamma / h**n * ratio, "alpha", alpha),
        coefficient(gamma * kp * ratio, "kp", kp),
        coefficient(gamma * kd / h * ratio, "kd", kd),
        coefficient(gamma * ki * h * ratio, "ki", ki),
        Coefficient.of(k_aw * h, f"{p}k_aw", k_aw, (30, 62)), aw,
        round(u_init / sc.u_scale * 2**31))
    if like is not None and _structure(q) != _structure(q31_intelligent(like)):
        raise ConfigError(f"{p}law", _structure(q), "must have the structure of the export "
                          f"it is for, {_structure(q31_intelligent(like))} (its order, "
                          "kernel and anti-windup are its code)")
    return q


def _structure(q: Q31Intelligent) -> str:
    """What fixes the exported code: the order, the held kernel's mean, the anti-windup."""
    kind = {intelligent.AW_NONE: "none", intelligent.AW_CLAMP: "clamp",
            intelligent.AW_BACK: "back-calculation"}[q.anti_windup]
    return f"order {q.order}, {'mean of the held inputs' if q.held_mean else 'u_h = u_1'}, " \
        f"anti-windup {kind}"


#: the coefficients of the tunable build, in the order of its parameter struct (member,
#: what it is, the shifts its products take); ``caw`` with the back-calculation only
_COEFFICIENTS = (
    ("cn", "gamma / h^n * @PU@_Y_SCALE / @PU@_U_SCALE (gamma = 1 / alpha), > 0", SHIFTS),
    ("cp", "gamma K_P * @PU@_Y_SCALE / @PU@_U_SCALE", SHIFTS),
    ("cd", "gamma K_D / h * @PU@_Y_SCALE / @PU@_U_SCALE", SHIFTS),
    ("ci", "gamma K_I h * @PU@_Y_SCALE / @PU@_U_SCALE", SHIFTS),
    ("caw", "K_aw h, in [0, 1]", (30, 62)),
)
_CHECKS = {
    "cn": ("alpha > 0", "p->cn.m <= 0"),
    "caw": ("K_aw h in [0, 1]: at 1 it undoes the whole excess at each limited sample",
            "p->caw.m < 0 || (p->caw.s == 30 && p->caw.m > 0x40000000L)"),
}
_APPLY = """\
    /* the output held (in manual mode, or after a rejected sample) within the new limits */
    s->last_output = @P@_clamp_code(s->last_output, @LIMITS@);
    if (s->mode == @PU@_MANUAL) return 0;
    if (s->fresh) /* before any sample: as init with them */
        @P@_restart(s, @P@_clamp_code(@PU@_U_INIT, @LIMITS@));
    else /* from it, as @P@_set_auto does from manual (the next @N@ samples hold it) */
        @P@_restart(s, s->last_output);
"""


def _members(q: Q31Intelligent):
    back = q.anti_windup == intelligent.AW_BACK
    return [(*m, 31) for m in _COEFFICIENTS if back or m[0] != "caw"]


def _tag(ctrl, q: Q31Intelligent) -> int:
    return _format(f"{type(ctrl).__name__}, {_structure(q)}", ctrl, q.scales)


def q31_intelligent_params_c(ctrl, key_prefix: str = "", like=None) -> str:
    """The C initializer of the tunable q31 i-P family's ``PREFIX_params`` for ``ctrl``
    (see :func:`mfcontrol.cexport.fixed_point.fixed_params_c`, which calls this one)."""
    q = q31_intelligent(ctrl, key_prefix, like)
    return params_c(_tag(like if like is not None else ctrl, q),
                    [(name, getattr(q, name)) for name, _, _, _ in _members(q)],
                    q.scales.u_limits)


def q31_intelligent_source(ctrl, *, prefix: str, banner: str, key_prefix: str = "",
                           frozen: bool = False) -> tuple[str, str]:
    """(header, source) of the q31 intelligent controller of ``ctrl``: its coefficients
    and output limits in a parameter struct that ``PREFIX_set_params`` checks and changes
    at run time, or constants with ``frozen``."""
    q = q31_intelligent(ctrl, key_prefix)
    coefficients = [(name.upper(), getattr(q, name)) for name, _, _, _ in _members(q)]
    PU = prefix.upper()
    has_i = q.ci.mantissa != 0  # frozen: no anti-windup without an integral
    subs = {"N": str(q.order), "UINIT": str(q.u_init), "MEAN": "1" if q.held_mean else "0",
            "BITS": BITS,
            "CLAMP": "1" if q.anti_windup == intelligent.AW_CLAMP and (has_i or not frozen)
            else "0",
            "BACK": "1" if q.anti_windup == intelligent.AW_BACK and (has_i or not frozen)
            else "0"}
    if frozen:
        subs |= {name: f"{PU}_{name}_M, {PU}_{name}_S" for name, _ in coefficients}
        subs |= {"DER": "1" if q.cd.mantissa else "0", "WITH_I": "",
                 "LIMITS": f"{PU}_U_LO, {PU}_U_HI", "LO": f"{PU}_U_LO", "HI": f"{PU}_U_HI",
                 "FRESH_0": "", "FRESH_0_IN": "", "FRESH_1": "", "FRESH_MEMBER": ""}
        subs |= dict.fromkeys(TUNABLE_PARTS, "")
    else:
        subs |= {name: f"s->params.{name.lower()}.m, s->params.{name.lower()}.s"
                 for name, _ in coefficients}
        lo, hi = (f"{PU}_WIDE(s->params.out_{end})" for end in ("min", "max"))
        subs |= {"DER": "1", "WITH_I": " && s->params.ci.m != 0",
                 "LIMITS": f"{lo}, {hi}", "LO": lo, "HI": hi,
                 "FRESH_0": "    s->fresh = 0;\n", "FRESH_0_IN": "        s->fresh = 0;\n",
                 "FRESH_1": "    s->fresh = 1;\n",
                 "FRESH_MEMBER": "    int fresh;              /* 1 until a sample is taken or "
                                 "the law restarts */\n"}
        subs |= tunable_parts(prefix, _members(q), q31_intelligent_params_c(ctrl, key_prefix),
                              _tag(ctrl, q), "the law's coefficients", _CHECKS, _APPLY)
    # without the back-calculation its code is left out by the preprocessor (#if 0)
    subs.setdefault("CAW", "0, 31")
    # the pieces first: the names in them are filled after
    subs = {key: subs[key] for key in (*TUNABLE_PARTS, "LIMITS")} | subs
    return q31_files(ctrl, q.scales, coefficients if frozen else [], prefix=prefix,
                     banner=banner, templates=(_HEADER, _SOURCE), subs=subs)


_HEADER = """@Q31_HEAD@@PARAMS@\
/* rejected samples in a row whose periods the next step spans; beyond, it spans this many
 * (the double law spans them all) */
#define @PU@_SKIP_MAX 255

typedef struct {
@STATE_PARAMS@    int64_t e1, e2;         /* the error's codes at the last two samples */
    int64_t u1, u2;         /* the last two applied outputs, output codes * 2^@F@ */
    int64_t t;              /* the integral term gamma K_I I, output codes * 2^@F@ */
    int k;                  /* samples taken since the start, up to the model order */
    int skipped;            /* samples rejected since the last one taken (up to
                             * @PU@_SKIP_MAX): the next step spans their periods */
    @P@_@Q@ last_output;    /* returned in manual mode and after a rejected sample */
@FRESH_MEMBER@    unsigned long nan_count; /* rejected: a measurement outside the input limits */
    /* @PU@_AUTO or @PU@_MANUAL (set by @P@_init, @P@_set_manual, @P@_set_auto); any other
     * value is a state never passed to @P@_init, which every function refuses */
    unsigned long mode;
} @P@_state;

/* Start (or restart) the controller: automatic mode, no history; the first @N@ samples
 * hold the starting output (no derivative exists before). */
void @P@_init(@P@_state *s);
/* One sample: the measurement and setpoint codes in, the limited output code out. A
 * measurement outside the input limits returns the last output and counts in nan_count;
 * the next sample taken spans its period (its differences and integral over the longer
 * time, as the double law's). Every sum saturates: no code overflows. On a state never
 * initialised: returns 0 clamped to the output limits and changes nothing. */
@P@_@Q@ @P@_step(@P@_state *s, @P@_@Q@ y, @P@_@Q@ setpoint);
/* Manual mode: every step returns u, clamped to the output limits, until @P@_set_auto. */
void @P@_set_manual(@P@_state *s, @P@_@Q@ u);
/* Back to automatic, restarting the law from the last output (bumpless: the next @N@
 * samples hold it). */
void @P@_set_auto(@P@_state *s);
@SET_PARAMS_DECL@@Q31_TAIL@"""

_SOURCE = """@Q31_PRELUDE@/* an output code in output codes * 2^F */
#define @PU@_WIDE(code) ((int64_t)(code) * ((int64_t)1 << @PU@_F))
/* the output limits exported, output codes * 2^F */
#define @PU@_U_LO @PU@_WIDE(@ULO@L)
#define @PU@_U_HI @PU@_WIDE(@UHI@L)
#define @PU@_U_INIT (@UINIT@L)
#define @PU@_N @N@
/* a term's bound, output codes * 2^F: five of them sum without overflow */
#define @PU@_T_MAX ((int64_t)1 << 59)

static int64_t @P@_sat(int64_t x)
{
    if (x > @PU@_T_MAX) return @PU@_T_MAX;
    if (x < -@PU@_T_MAX) return -@PU@_T_MAX;
    return x;
}

/* x * M * 2^(F - s), rounded to nearest and saturated to +-T_MAX, for |x| < 2^40,
 * |M| < 2^31 and -15 <= s <= 62: x = hi 2^16 + lo (0 <= lo < 2^16), x M = a 2^16 + b,
 * b = bh 2^16 + bl, so x M = t 2^16 + bl with |t| < 2^56: no product overflows */
static int64_t @P@_mul(int64_t x, int64_t m, int s)
{
    int64_t hi = x >> 16, lo, a, b, bh, bl, t;
    int r = s - @PU@_F; /* the shift in output codes * 2^F */
    if (m == 0) return 0;
    lo = x - hi * 65536;
    a = hi * m;
    b = lo * m;
    bh = b >> 16;
    bl = b - bh * 65536;
    t = a + bh;
    if (r >= 16)  /* floor((t 2^16 + bl + 2^(r-1)) / 2^r), in two exact steps */
        return @P@_sat((t + ((bl + ((int64_t)1 << (r - 1))) >> 16)) >> (r - 16));
    /* r < 16: t 2^(16 - r) + bl 2^-r; saturated where t alone is past the bound */
    if (t >= ((int64_t)1 << (43 + r))) return @PU@_T_MAX;
    if (t <= -((int64_t)1 << (43 + r))) return -@PU@_T_MAX;
    if (r > 0)
        return @P@_sat(t * ((int64_t)1 << (16 - r)) + ((bl + ((int64_t)1 << (r - 1))) >> r));
    return @P@_sat(t * ((int64_t)1 << (16 - r)) + bl * ((int64_t)1 << -r));
}

#if @BACK@
/* x * M * 2^-s, rounded to nearest and saturated to +-T_MAX, for a coefficient of at
 * most 1 (k_aw h, refused above 1: s >= 30) and any x (saturated to +-2^61 first):
 * x = hi 2^30 + lo (0 <= lo < 2^30), hi M < 2^62 and lo M < 2^61 */
static int64_t @P@_scale(int64_t x, int64_t m, int s)
{
    int64_t hi, lo;
    if (x > ((int64_t)1 << 61)) x = (int64_t)1 << 61;
    if (x < -((int64_t)1 << 61)) x = -((int64_t)1 << 61);
    hi = x >> 30;
    lo = x - hi * ((int64_t)1 << 30);
    return @P@_sat((hi * m + ((lo * m + ((int64_t)1 << (s - 1))) >> 30)) >> (s - 30));
}
#endif

@BITS@/* x * M * 2^(F - s) / D (D in [2, 2^16]), rounded and saturated to +-T_MAX as mul: the
 * product taken over 2^k >= D (it saturates only where the quotient does), then times
 * 2^k / D in [1, 2) through a 16-bit split */
static int64_t @P@_mul_over(int64_t x, int64_t m, int s, int64_t D)
{
    int k = @P@_bits(D - 1);  /* the least k with 2^k >= D */
    int64_t p, c, p1, p0, a, q, low;
    p = @P@_mul(x, m, s + k);
    if (p >= @PU@_T_MAX || p <= -@PU@_T_MAX) return p;
    c = ((int64_t)1 << k) - D;
    p1 = p >> 16;
    p0 = p - p1 * 65536;
    a = p1 * c;
    q = a >= 0 ? a / D : -((-a + D - 1) / D);
    low = (a - q * D) * 65536 + p0 * c;
    return @P@_sat(p + q * 65536 + (low + D / 2) / D);
}

/* x * d saturated to +-T_MAX (|x| <= T_MAX, d in [1, 256]: the periods since the last
 * sample taken). Within +-2^51 it cannot saturate (d <= 2^8): the 64-bit divisions that
 * find where it would (a library call each on a Cortex-M) only beyond */
static int64_t @P@_times(int64_t x, int64_t d)
{
    if (x > ((int64_t)1 << 51) || x < -((int64_t)1 << 51)) {
        if (x > @PU@_T_MAX / d) return @PU@_T_MAX;
        if (x < -@PU@_T_MAX / d) return -@PU@_T_MAX;
    }
    return x * d;
}

static int64_t @P@_limit(int64_t v, int64_t lo, int64_t hi)
{
    return v > hi ? hi : (v < lo ? lo : v);
}

/* the output code of a guarded output (within the limits: no overflow) */
static @P@_@Q@ @P@_code(int64_t u)
{
    return (@P@_@Q@)((u + ((int64_t)1 << (@PU@_F - 1))) >> @PU@_F);
}

static void @P@_restart(@P@_state *s, @P@_@Q@ u)
{
    s->e1 = 0;
    s->e2 = 0;
    s->u1 = (int64_t)u * ((int64_t)1 << @PU@_F);
    s->u2 = s->u1;
    s->t = 0;
    s->k = 0;
    s->skipped = 0;
    s->last_output = u;
}

static @P@_@Q@ @P@_clamp_code(int64_t u, int64_t lo_wide, int64_t hi_wide)
{
    int64_t lo = lo_wide >> @PU@_F, hi = hi_wide >> @PU@_F;
    return (@P@_@Q@)(u > hi ? hi : (u < lo ? lo : u));
}

void @P@_init(@P@_state *s)
{
@INIT_PARAMS@    @P@_restart(s, @P@_clamp_code(@PU@_U_INIT, @LIMITS@));
@FRESH_1@    s->nan_count = 0;
    s->mode = @PU@_AUTO;
}

@P@_@Q@ @P@_step(@P@_state *s, @P@_@Q@ y, @P@_@Q@ setpoint)
{
    int64_t e, uh, base, t, v, u, d;
    if (s->mode != @PU@_AUTO) /* manual; or never initialised: within the limits, unchanged */
        return s->mode == @PU@_MANUAL ? s->last_output
                                          : @P@_clamp_code(0, @PU@_U_LO, @PU@_U_HI);
    if (y < @PU@_Y_LO || y > @PU@_Y_HI) {
        s->nan_count++;
        if (s->skipped < @PU@_SKIP_MAX) s->skipped++;
        return s->last_output;
    }
    e = (int64_t)y - setpoint;
    d = (int64_t)s->skipped + 1; /* the period since the last sample taken, in periods */
    s->skipped = 0;
@FRESH_0@    if (s->k < @PU@_N) {  /* no derivative yet: the output holds */
        s->k++;
        u = s->u1;
    } else {
#if @MEAN@
        uh = (s->u1 + s->u2 + 1) >> 1;  /* the held kernel's input, rounded */
#else
        uh = s->u1;
#endif
#if @N@ == 2
        base = d > 1 ? @P@_mul_over(e - 2 * s->e1 + s->e2, @CN@, d * d)
                     : @P@_mul(e - 2 * s->e1 + s->e2, @CN@);
#else
        base = d > 1 ? @P@_mul_over(e - s->e1, @CN@, d) : @P@_mul(e - s->e1, @CN@);
#endif
#if @DER@
        {
            base += d > 1 ? @P@_mul_over(e - s->e1, @CD@, d) : @P@_mul(e - s->e1, @CD@);
        }
#endif
        base += @P@_mul(e, @CP@);
        t = @P@_mul(e, @CI@);
        t = @P@_sat(s->t + (d > 1 ? @P@_times(t, d) : t));
        v = uh - base - t;
        u = @P@_limit(v, @LIMITS@);
#if @CLAMP@
        /* integrating pushed the output further past the limit it hit: undo it */
        if ((v > @HI@ && t < s->t) || (v < @LO@ && t > s->t)) {
            t = s->t;
            v = uh - base - t;
            u = @P@_limit(v, @LIMITS@);
        }
#endif
#if @BACK@
        if (u != v@WITH_I@) {
            int64_t c = @P@_scale(u - v, @CAW@);
            t = @P@_sat(t - (d > 1 ? @P@_times(c, d) : c));
        }
#endif
        s->t = t;
    }
    s->e2 = s->e1;
    s->e1 = e;
    s->u2 = s->u1;
    s->u1 = u;
    s->last_output = @P@_code(u);
    return s->last_output;
}

void @P@_set_manual(@P@_state *s, @P@_@Q@ u)
{
    if (!@PU@_INITIALISED(s)) return;
    s->mode = @PU@_MANUAL;
    s->last_output = @P@_clamp_code(u, @LIMITS@);
}

void @P@_set_auto(@P@_state *s)
{
    if (!@PU@_INITIALISED(s)) return;
    /* from manual: restart from the last output, as the live controller does */
    if (s->mode == @PU@_MANUAL) {
        @P@_restart(s, s->last_output);
@FRESH_0_IN@    }
    s->mode = @PU@_AUTO;
}
@SETTER@"""
