"""The PID as fixed-point C (``real="q31"``), for a microcontroller without a floating-point
unit (a Cortex-M0), where software floating point costs thousands of instructions a step.

Not a translation: integers need formats the law's Python does not carry. This is the PID
of :mod:`mfcontrol.laws.pid` written out in integer arithmetic, every coefficient
computed here from the controller's parameters, and held to the double law by tests
(``tests/cexport/test_fixed_point.py``: within an error bound derived step by step on the
case's closed loop, with hostile codes, and with the same bits on a Cortex-M0 as on x86).

Formats. A signal is an ``int32_t`` code. The measurement and the setpoint:
``y = Y * Y_SCALE / 2^31``, with ``Y_SCALE`` twice the larger magnitude of the input
limits (the sensor's range, required), so that the difference of two codes fits an int32.
The output: ``u = U * U_SCALE / 2^31``, ``U_SCALE`` :data:`U_HEADROOM` times the larger
magnitude of the output limits (required finite), so that the terms before the limits (a
derivative kick, the unlimited output the back-calculation sees) have room up to that
many times the limits before they saturate. A coefficient c is ``M 2^-s`` with ``M`` in
[2^30, 2^31), its relative error at most 2^-31; a product of a code and a coefficient is
formed in 64 bits and shifted back, rounded to nearest. The integral is held in 64 bits
with :data:`GUARD_BITS` more fraction bits than the output's code, and every sum
saturates. A rejected sample (a measurement outside the input limits) holds the output;
the next step uses the nominal period (the double law spans the time since the last
sample taken). There is no run-time setter: the coefficients are constants.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import ConfigError
from ..laws import pid

#: fraction bits of the integral beyond the output's code: an increment ki h e of one
#: code of e in a year of 1 kHz samples still moves it
GUARD_BITS = 24
#: the output's scale over the output limits' magnitude: room for the terms before limiting
U_HEADROOM = 16
_ONE = 2**31


@dataclass(frozen=True)
class Coefficient:
    """``value`` as ``mantissa * 2^-shift`` (``mantissa`` in [2^30, 2^31) or 0)."""

    value: float
    mantissa: int
    shift: int

    @classmethod
    def of(cls, value: float, name: str, given: float | None = None,
           shifts: tuple[int, int] = (1, 62)) -> Coefficient:
        """``value`` in q31, refused in the words of ``name = given`` (the parameter it
        comes from, as the user gave it; default ``value``) where its shift is outside
        ``shifts`` (what the C's products take)."""
        given = value if given is None else given
        if value == 0.0:
            return cls(0.0, 0, 31)
        if not math.isfinite(value):
            raise ConfigError(name, given, "must be finite for a fixed-point export")
        shift = 30 - math.floor(math.log2(abs(value)))
        mantissa = round(abs(value) * 2.0**shift)
        if mantissa == _ONE:  # rounded up to the next power of two
            mantissa, shift = _ONE // 2, shift - 1
        if not shifts[0] <= shift <= shifts[1]:
            raise ConfigError(name, given, f"gives the q31 coefficient {value:.3g} (in the "
                              "codes' units), outside what one holds (2^"
                              f"{30 - shifts[1]} to 2^{31 - shifts[0]}): export in float, "
                              "or change the scales (input and output limits)")
        return cls(value, int(math.copysign(mantissa, value)), shift)

    @property
    def exact(self) -> float:
        """The value the C multiplies by."""
        return self.mantissa * 2.0**-self.shift


@dataclass(frozen=True)
class Scales:
    """A fixed-point export's signal formats: the full scales of the measurement (and the
    setpoint) and of the output, and the codes of their limits."""

    y_scale: float
    u_scale: float
    y_limits: tuple[int, int]  # codes of the input limits
    u_limits: tuple[int, int]  # codes of the output limits
    u_lo: float  # the output limits themselves
    u_hi: float


@dataclass(frozen=True)
class Q31Pid:
    """The scales and coefficients of a PID's q31 export."""

    scales: Scales
    b: Coefficient
    c: Coefficient
    kp: Coefficient  # kp Y_SCALE / U_SCALE
    kih: Coefficient  # ki h Y_SCALE / U_SCALE 2^GUARD_BITS
    htt: Coefficient  # h / Tt 2^GUARD_BITS
    ad: Coefficient
    bd: Coefficient  # bd Y_SCALE / U_SCALE
    derivative: bool


def code(value: float, scale: float) -> int:
    """The int32 code of ``value`` at full scale ``scale``, rounded and saturated."""
    return int(round(min(max(value / scale * _ONE, -_ONE + 1.0), _ONE - 1.0)))


def scales(ctrl, lo: float, hi: float, key_prefix: str = "") -> Scales:
    """The formats of a live controller with output limits (lo, hi): ``Y_SCALE`` twice the
    larger magnitude of its input limits (required: the sensor's range), ``U_SCALE``
    :data:`U_HEADROOM` times that of the output limits (required finite)."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or max(abs(lo), abs(hi)) == 0.0:
        raise ConfigError(f"{key_prefix}output_limits", [lo, hi], "must be finite and not "
                          "both 0 for a fixed-point export (they set the output's scale)")
    y_lo, y_hi = ctrl.input_limits
    if y_lo is None or y_hi is None or max(abs(y_lo), abs(y_hi)) == 0.0:
        raise ConfigError("input_limits", [y_lo, y_hi], "a fixed-point export needs the "
                          "measurement's range (the sensor's) for its scale: both limits "
                          "finite, not both 0 (--input-limits LOW HIGH, input_limits=)")
    sy = 2.0 * max(abs(y_lo), abs(y_hi))
    su = U_HEADROOM * max(abs(lo), abs(hi))
    return Scales(sy, su, (code(y_lo, sy), code(y_hi, sy)), (code(lo, su), code(hi, su)),
                  lo, hi)


def q31_pid(ctrl, key_prefix: str = "") -> Q31Pid:
    """The q31 formats of a live :class:`mfcontrol.PID` (refusing what they cannot hold)."""
    cp = ctrl._CP[:, 0]
    sc = scales(ctrl, float(cp[pid.OUT_MIN]), float(cp[pid.OUT_MAX]), key_prefix)
    if cp[pid.TF] != 0.0:
        raise ConfigError(f"{key_prefix}Tf", float(cp[pid.TF]), "the fixed-point PID has no "
                          "measurement filter yet: export with Tf 0, or in float")
    h = ctrl.sample_time
    sy, su = sc.y_scale, sc.u_scale
    ratio = sy / su
    kp, ki, kd, n = (float(cp[row]) for row in (pid.KP, pid.KI, pid.KD, pid.N))
    tt = float(cp[pid.TT])
    derivative = kd != 0.0
    # the law's own coefficients at the nominal period
    kih, htt, ad, bd, _, _ = pid.coefficients(ctrl._CP, 0, h)
    guard = 2.0**GUARD_BITS
    p = key_prefix
    return Q31Pid(
        sc,
        Coefficient.of(float(cp[pid.B]), f"{p}b"), Coefficient.of(float(cp[pid.C]), f"{p}c"),
        Coefficient.of(kp * ratio, f"{p}kp", kp),
        Coefficient.of(kih * ratio * guard, f"{p}ki", ki),
        Coefficient.of(htt * guard, f"{p}Tt", tt),
        Coefficient.of(ad, f"{p}N", n), Coefficient.of(bd * ratio, f"{p}kd", kd), derivative)


def q31_source(ctrl, *, prefix: str, banner: str, key_prefix: str = "") -> tuple[str, str]:
    """(header, source) of the q31 PID of ``ctrl``."""
    q = q31_pid(ctrl, key_prefix)
    coefficients = (("B", q.b), ("C", q.c), ("KP", q.kp), ("KIH", q.kih), ("HTT", q.htt),
                    ("AD", q.ad), ("BD", q.bd))
    return q31_files(ctrl, q.scales, coefficients, prefix=prefix, banner=banner,
                     templates=(_HEADER, _SOURCE),
                     subs={"DER": "1" if q.derivative else "0",
                           "CW": "1" if q.c.mantissa else "0"})


def q31_files(ctrl, sc: Scales, coefficients, *, prefix: str, banner: str,
              templates: tuple[str, str], subs: dict[str, str]) -> tuple[str, str]:
    """(header, source) of a fixed-point law from its templates: their shared opening
    lines (``@Q31_HEAD@``, ``@Q31_TAIL@`` in the header, ``@Q31_PRELUDE@`` in the source:
    the formats, the modes, the coefficients ``(NAME, Coefficient)`` as
    ``PREFIX_NAME_M`` and ``PREFIX_NAME_S``) and the law's own ``subs`` filled in."""
    PU = prefix.upper()
    consts = "".join(f"#define {PU}_{name}_M ({c.mantissa}L)\n#define {PU}_{name}_S {c.shift}\n"
                     for name, c in coefficients)
    every = {"Q31_HEAD": _Q31_HEAD, "Q31_TAIL": _Q31_TAIL, "Q31_PRELUDE": _Q31_PRELUDE,
             **subs, "P": prefix, "PU": PU, "CONSTS": consts, "BANNER": banner,
             "YLO": str(sc.y_limits[0]), "YHI": str(sc.y_limits[1]),
             "ULO": str(sc.u_limits[0]), "UHI": str(sc.u_limits[1]),
             "YS": repr(sc.y_scale), "US": repr(sc.u_scale), "DT": repr(ctrl.sample_time),
             "F": str(GUARD_BITS)}
    header, source = templates
    for key, value in every.items():
        header = header.replace(f"@{key}@", value)
        source = source.replace(f"@{key}@", value)
    return header, source


#: the fixed-point headers' opening lines: the formats, the sample period and the modes
_Q31_HEAD = """@BANNER@
#ifndef MFCONTROL_@P@_H
#define MFCONTROL_@P@_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* q31 codes: the measurement and the setpoint are y = Y * @PU@_Y_SCALE / 2^31, the
 * output u = U * @PU@_U_SCALE / 2^31 (int32_t; the scales in the physical units) */
typedef int32_t @P@_q31;
#define @PU@_Y_SCALE @YS@
#define @PU@_U_SCALE @US@
/* sample period (s) the law was built for: call @P@_step once per period */
#define @PU@_SAMPLE_TIME @DT@
/* a state's mode: automatic ("mfc1"), manual ("mfc0") */
#define @PU@_AUTO 0x6D666331UL
#define @PU@_MANUAL 0x6D666330UL
"""

#: and their closing lines
_Q31_TAIL = """
#ifdef __cplusplus
}
#endif

#endif
"""

#: the fixed-point sources' opening lines: the shift they rely on, the coefficients, the
#: measurement's limits, the guard bits and the test of an initialised state
_Q31_PRELUDE = """@BANNER@
#include "@P@.h"

/* the right shift of a negative integer is arithmetic on every compiler this targets;
 * the build stops where it is not */
typedef char @P@_arithmetic_shift[((-1L) >> 1) == -1L ? 1 : -1];

/* the coefficients, M * 2^-S with |M| in [2^30, 2^31), or 0
 * (mfcontrol.cexport.fixed_point) */
@CONSTS@#define @PU@_Y_LO (@YLO@L)
#define @PU@_Y_HI (@YHI@L)
#define @PU@_F @F@
/* a state passed to @P@_init: its mode is one of the two */
#define @PU@_INITIALISED(s) ((s)->mode == @PU@_AUTO || (s)->mode == @PU@_MANUAL)
"""


_HEADER = """@Q31_HEAD@
typedef struct {
    int64_t i;              /* the integral, in output codes * 2^@F@ */
    int32_t d;              /* the derivative term, output codes */
    int32_t y_old, r_old;   /* the last sample's measurement and setpoint */
    int32_t start;          /* the output the next sample is set to give (bumpless) */
    int32_t last_output;    /* returned in manual mode and after a rejected sample */
    unsigned long nan_count; /* rejected: a measurement outside the input limits */
    int started;            /* 0 until the first sample is taken */
    int pending;            /* 1 while start waits for the next sample */
    /* @PU@_AUTO or @PU@_MANUAL (set by @P@_init, @P@_set_manual, @P@_set_auto); any other
     * value is a state never passed to @P@_init, which every function refuses */
    unsigned long mode;
} @P@_state;

/* Start (or restart) the controller: automatic mode, no history. */
void @P@_init(@P@_state *s);
/* One sample: the measurement and setpoint codes in, the limited output code out. A
 * measurement outside the input limits returns the last output and counts in nan_count.
 * Every sum saturates: no code overflows. On a state never initialised: returns 0
 * clamped to the output limits and changes nothing. */
@P@_q31 @P@_step(@P@_state *s, @P@_q31 y, @P@_q31 setpoint);
/* Manual mode: every step returns u, clamped to the output limits, until @P@_set_auto. */
void @P@_set_manual(@P@_state *s, @P@_q31 u);
/* Back to automatic, restarting the law from the last output (bumpless). */
void @P@_set_auto(@P@_state *s);
@Q31_TAIL@"""

_SOURCE = """@Q31_PRELUDE@#define @PU@_U_LO (@ULO@L)
#define @PU@_U_HI (@UHI@L)
#define @PU@_I_MAX ((int64_t)1 << 61)
#define @PU@_T_MAX ((int64_t)1 << (61 - @PU@_F))

static int32_t @P@_sat32(int64_t x)
{
    if (x > INT32_MAX) return INT32_MAX;
    if (x < -INT32_MAX) return -INT32_MAX;
    return (int32_t)x;
}

/* the integral's bound: the integral and two products (each below 2^61) sum without
 * overflow */
static int64_t @P@_sat_i(int64_t x)
{
    if (x > @PU@_I_MAX) return @PU@_I_MAX;
    if (x < -@PU@_I_MAX) return -@PU@_I_MAX;
    return x;
}

/* x * M * 2^-S, rounded to nearest (|x| < 2^31, |M| < 2^31: the product and the half
 * fit 63 bits, and the result is below 2^61) */
static int64_t @P@_mul(int32_t x, int64_t m, int shift)
{
    return ((int64_t)x * m + ((int64_t)1 << (shift - 1))) >> shift;
}

static int32_t @P@_clamp(int64_t v)
{
    return (int32_t)(v > @PU@_U_HI ? @PU@_U_HI : (v < @PU@_U_LO ? @PU@_U_LO : v));
}

void @P@_init(@P@_state *s)
{
    s->i = 0;
    s->d = 0;
    s->y_old = 0;
    s->r_old = 0;
    s->start = 0;
    s->last_output = @P@_clamp(0);
    s->nan_count = 0;
    s->started = 0;
    s->pending = 0;
    s->mode = @PU@_AUTO;
}

@P@_q31 @P@_step(@P@_state *s, @P@_q31 y, @P@_q31 setpoint)
{
    int64_t p, d = 0, v;
    int32_t u;
    if (s->mode != @PU@_AUTO) /* manual; or never initialised: within the limits, unchanged */
        return s->mode == @PU@_MANUAL ? s->last_output : @P@_clamp(0);
    if (y < @PU@_Y_LO || y > @PU@_Y_HI) {
        s->nan_count++;
        return s->last_output;
    }
    if (!s->started) {
        s->y_old = y;
        s->r_old = setpoint;
    }
    p = @P@_mul(@P@_sat32(@P@_mul(setpoint, @PU@_B_M, @PU@_B_S) - y), @PU@_KP_M, @PU@_KP_S);
#if @DER@
    {
#if @CW@
        int64_t de = (y - @P@_mul(setpoint, @PU@_C_M, @PU@_C_S))
                     - (s->y_old - @P@_mul(s->r_old, @PU@_C_M, @PU@_C_S));
#else
        int64_t de = (int64_t)y - s->y_old;
#endif
        d = @P@_mul(s->d, @PU@_AD_M, @PU@_AD_S) - @P@_mul(@P@_sat32(de), @PU@_BD_M, @PU@_BD_S);
        d = @P@_sat32(d);
    }
#endif
    if (s->pending) {  /* the bumpless start: the integral that gives `start` */
        int64_t t = (int64_t)s->start - p - d;
        if (t > @PU@_T_MAX) t = @PU@_T_MAX;
        if (t < -@PU@_T_MAX) t = -@PU@_T_MAX;
        s->i = t * ((int64_t)1 << @PU@_F);
        s->pending = 0;
    }
    v = p + ((s->i + ((int64_t)1 << (@PU@_F - 1))) >> @PU@_F) + d;
    u = @P@_clamp(v);
    s->i = @P@_sat_i(s->i + @P@_mul(@P@_sat32((int64_t)setpoint - y), @PU@_KIH_M, @PU@_KIH_S)
                     + @P@_mul(@P@_sat32((int64_t)u - v), @PU@_HTT_M, @PU@_HTT_S));
    s->d = (int32_t)d;
    s->y_old = y;
    s->r_old = setpoint;
    s->started = 1;
    s->last_output = u;
    return u;
}

void @P@_set_manual(@P@_state *s, @P@_q31 u)
{
    if (!@PU@_INITIALISED(s)) return;
    s->mode = @PU@_MANUAL;
    s->last_output = @P@_clamp(u);
}

void @P@_set_auto(@P@_state *s)
{
    if (!@PU@_INITIALISED(s)) return;
    /* from manual: restart from the last output, as the live PID's reset does */
    if (s->mode == @PU@_MANUAL) {
        s->i = 0;
        s->d = 0;
        s->started = 0;
        s->start = s->last_output;
        s->pending = 1;
    }
    s->mode = @PU@_AUTO;
}
"""
