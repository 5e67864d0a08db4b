"""The PID as fixed-point C (``real="q31"`` or ``"q15"``), for a microcontroller without a
floating-point unit (a Cortex-M0), where software floating point costs thousands of
instructions a step.

Not a translation: integers need formats the law's Python does not carry. This is the PID
of :mod:`mfcontrol.laws.pid` written out in integer arithmetic, every coefficient
computed here from the controller's parameters, and held to the double law by tests
(``tests/cexport/test_fixed_point.py``: within an error bound derived step by step on the
case's closed loop, with hostile codes, and with the same bits on a Cortex-M0 as on x86).

Words (:data:`WORDS`). In q31 a signal is an ``int32_t`` code of 31 bits and a sign, a
coefficient's mantissa has 31 bits, and a code times a coefficient is formed in 64 bits
(on a Cortex-M0 a library call). In q15 a signal is an ``int16_t`` code, a coefficient's
mantissa has 15 bits (relative error at most 2^-15), and the product is formed in 32 bits
(one ``MULS``): about half the cycles on a Cortex-M0, for a code of 2^-15 of the scale.
The integral and the measurement filter are 64-bit in both.

Formats. The measurement and the setpoint: ``y = Y * Y_SCALE / 2^B`` (B = 31 or 15), with
``Y_SCALE`` twice the larger magnitude of the input limits (the sensor's range,
required), so that the difference of two codes within them fits a code (but for the one
extreme, 2^B, which saturates to 2^B - 1). The output: ``u = U *
U_SCALE / 2^B``, ``U_SCALE`` the word's headroom (16 in q31, 4 in q15) times the larger
magnitude of the output limits (required finite), so that the terms before the limits (a
derivative kick, the unlimited output the back-calculation sees) have room up to that
many times the limits before they saturate. A coefficient c is ``M 2^-s`` with ``|M|``
in [2^(B-1), 2^B); a product of a code and a coefficient is shifted back, rounded to
nearest. The integral is held in 64 bits with :data:`GUARD_BITS` more fraction bits than
the output's code, and every sum saturates. A rejected sample (a measurement outside the
input limits) holds the output, and the next sample taken spans the time since the last
one as the double law does, for up to 255 rejected in a row: the integral's increments
times the d periods, the derivative divided by ``1 + (d - 1)(1 - ad)`` (its coefficients
at d h; a 64-bit division on that step only). The measurement filter (``Tf`` > 0) runs on
the measurement's code times ``2^GUARD_BITS`` in 64 bits with q31 coefficients: its state
is the filtered value ``x`` and its increment over a period ``w``, stepped as ``w = fa w
+ fb (y - x)``, ``x = x + w`` (the double law's backward difference, ``fa = 1 / fden``,
``fb = h c / fden``), and over d periods after a dropout as ``w = (fa w + d fb (y - x)) /
Q``, ``x = x + d w``, ``Q = 1 + (d - 1)(1 - fa + d fb)`` (the same algebra at d h). The
coefficients and the output limits' codes are a parameter struct that
``PREFIX_set_params`` checks and changes at run time (:func:`fixed_params_c` writes one
for new gains), or constants with ``frozen``.
"""

from __future__ import annotations

import math
import re
import zlib
from dataclasses import dataclass, replace

from ..errors import ConfigError
from ..laws import pid
from .source import _fill

#: fraction bits of the integral beyond the output's code: an increment ki h e of one
#: code of e in a year of 1 kHz samples still moves it
GUARD_BITS = 24


@dataclass(frozen=True)
class Word:
    """A fixed-point export's word: its codes' C type and fraction bits, the type a code
    times a coefficient is formed in, and the output's scale over the output limits'
    magnitude (room for the terms before limiting: a derivative kick, the unlimited
    output the back-calculation sees)."""

    name: str  # what --real says: q31, q15
    bits: int  # a code is an integer of this many bits and a sign
    code: str  # its C type
    product: str  # the C type of a code times a coefficient (both of ``bits`` bits)
    headroom: int  # U_SCALE over the output limits' magnitude

    @property
    def code_max(self) -> str:
        """The C name of the largest code."""
        return f"INT{self.bits + 1}_MAX"


#: q31: codes of 31 bits, products in 64 (on a Cortex-M0, a library call each); q15:
#: codes of 15 bits, products in 32 (one MULS), less headroom to keep the output's
#: resolution (its limits are +-2^13 codes)
WORDS = {"q31": Word("q31", 31, "int32_t", "int64_t", 16),
         "q15": Word("q15", 15, "int16_t", "int32_t", 4)}


@dataclass(frozen=True)
class Coefficient:
    """``value`` as ``mantissa * 2^-shift`` (``|mantissa|`` in [2^(bits - 1), 2^bits) or
    0: ``bits`` 31 in q31, 15 in q15)."""

    value: float
    mantissa: int
    shift: int

    @classmethod
    def of(cls, value: float, name: str, given: float | None = None,
           shifts: tuple[int, int] = (1, 62), bits: int = 31) -> Coefficient:
        """``value`` with a mantissa of ``bits`` bits (31: q31's, 15: q15's), refused in
        the words of ``name = given`` (the parameter it comes from, as the user gave it;
        default ``value``) where its shift is outside ``shifts`` (what the C's products
        take)."""
        given = value if given is None else given
        if value == 0.0:  # a shift the products take (q15's shift 30 at most)
            return cls(0.0, 0, min(31, shifts[1]))
        if not math.isfinite(value):
            raise ConfigError(name, given, "must be finite for a fixed-point export")
        shift = bits - 1 - math.floor(math.log2(abs(value)))
        mantissa = round(abs(value) * 2.0**shift)
        if mantissa == 2**bits:  # rounded up to the next power of two
            mantissa, shift = 2 ** (bits - 1), shift - 1
        if not shifts[0] <= shift <= shifts[1]:
            raise ConfigError(name, given, f"gives the q{bits} coefficient {value:.3g} (in "
                              "the codes' units), outside what one holds (2^"
                              f"{bits - 1 - shifts[1]} to 2^{bits - shifts[0]}): export in "
                              "float, or change the scales (input and output limits)")
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
    word: Word = WORDS["q31"]  # the codes' word


@dataclass(frozen=True)
class FixedPid:
    """The scales (with the word) and coefficients of a PID's fixed-point export."""

    scales: Scales
    b: Coefficient
    c: Coefficient
    kp: Coefficient  # kp Y_SCALE / U_SCALE
    kih: Coefficient  # ki h Y_SCALE / U_SCALE 2^GUARD_BITS
    htt: Coefficient  # h / Tt 2^GUARD_BITS
    ad: Coefficient
    bd: Coefficient  # bd Y_SCALE / U_SCALE
    derivative: bool
    fa: Coefficient  # the measurement filter's 1 / fden (0: no filter)
    fb: Coefficient  # and its h c / fden


def code(value: float, scale: float, bits: int = 31) -> int:
    """The code of ``value`` at full scale ``scale`` (``bits`` bits and a sign: 31 an
    int32's, 15 an int16's), rounded and saturated."""
    one = 2.0**bits
    return int(round(min(max(value / scale * one, -one + 1.0), one - 1.0)))


def scales(ctrl, lo: float, hi: float, key_prefix: str = "",
           word: Word = WORDS["q31"]) -> Scales:
    """The formats of a live controller with output limits (lo, hi) in ``word``:
    ``Y_SCALE`` twice the larger magnitude of its input limits (required: the sensor's
    range), ``U_SCALE`` the word's headroom times that of the output limits (required
    finite)."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or max(abs(lo), abs(hi)) == 0.0:
        raise ConfigError(f"{key_prefix}output_limits", [lo, hi], "must be finite and not "
                          "both 0 for a fixed-point export (they set the output's scale)")
    y_lo, y_hi = ctrl.input_limits
    if y_lo is None or y_hi is None or max(abs(y_lo), abs(y_hi)) == 0.0:
        raise ConfigError("input_limits", [y_lo, y_hi], "a fixed-point export needs the "
                          "measurement's range (the sensor's) for its scale: both limits "
                          "finite, not both 0 (--input-limits LOW HIGH, input_limits=)")
    sy = 2.0 * max(abs(y_lo), abs(y_hi))
    su = word.headroom * max(abs(lo), abs(hi))
    b = word.bits
    return Scales(sy, su, (code(y_lo, sy, b), code(y_hi, sy, b)),
                  (code(lo, su, b), code(hi, su, b)), lo, hi, word)


def export_scales(ctrl, key_prefix: str = "", like=None,
                  word: Word = WORDS["q31"]) -> Scales:
    """The formats of a fixed-point export of the live controller ``ctrl``; with
    ``like``, the controller an export was made from, that export's, with ``ctrl``'s
    output limits as codes in them (refused where they do not fit, or where the periods
    differ: the coefficients are per period)."""
    lo, hi = (float(ctrl._CP[row, 0]) for row in ctrl._OUT_ROWS)
    if like is None:
        return scales(ctrl, lo, hi, key_prefix, word)
    if type(like) is not type(ctrl):
        raise ConfigError("like", type(like).__name__, f"must be the law of the set, "
                          f"{type(ctrl).__name__}: a set is for an export of its own law")
    like_lo, like_hi = (float(like._CP[row, 0]) for row in like._OUT_ROWS)
    sc = scales(like, like_lo, like_hi, word=word)
    if ctrl.sample_time != like.sample_time:
        raise ConfigError(f"{key_prefix}sample_time", ctrl.sample_time, "must be the "
                          f"export's, {like.sample_time!r}: its coefficients are per period")
    if not max(abs(lo), abs(hi)) <= sc.u_scale:
        raise ConfigError(f"{key_prefix}output_limits", [lo, hi], "must be within the "
                          f"export's output scale, +-{sc.u_scale!r}")
    b = sc.word.bits
    return replace(sc, u_limits=(code(lo, sc.u_scale, b), code(hi, sc.u_scale, b)), u_lo=lo,
                   u_hi=hi)


def fixed_pid(ctrl, key_prefix: str = "", like=None, real: str = "q31") -> FixedPid:
    """The fixed-point formats (``real``: q31 or q15) of a live :class:`mfcontrol.PID`
    (refusing what they cannot hold); with ``like``, the PID an export was made from, in
    that export's formats."""
    word = WORDS[real]
    cp = ctrl._CP[:, 0]
    sc = export_scales(ctrl, key_prefix, like, word)
    h = ctrl.sample_time
    sy, su = sc.y_scale, sc.u_scale
    ratio = sy / su
    kp, ki, kd, n = (float(cp[row]) for row in (pid.KP, pid.KI, pid.KD, pid.N))
    tt = float(cp[pid.TT])
    derivative = kd != 0.0
    # the law's own coefficients at the nominal period
    kih, htt, ad, bd, fc, fden = pid.coefficients(ctrl._CP, 0, h)
    guard = 2.0**GUARD_BITS
    p = key_prefix
    kinds = _KINDS[real]

    def coefficient(member: str, value: float, name: str, given: float) -> Coefficient:
        shifts, bits = kinds[_KIND[member]]
        return Coefficient.of(value, f"{p}{name}", given, shifts, bits)

    fa = fb = Coefficient(0.0, 0, 31)
    tf = float(cp[pid.TF])
    if tf > 0.0 and like is not None and like._CP[pid.TF, 0] == 0.0:
        raise ConfigError(f"{p}Tf", tf, "must be 0 for this export: it was made without a "
                          "measurement filter (Tf 0) and has no code to run one; export "
                          "with a Tf > 0 to tune one at run time")
    if tf > 0.0:  # both below 1: shifts of 31 or more
        try:
            fa = coefficient("fa", 1.0 / fden, "Tf", tf)
            fb = coefficient("fb", h * fc / fden, "Tf", tf)
        except ConfigError:
            raise ConfigError(f"{p}Tf", tf, f"gives the measurement filter's coefficients "
                              f"{1.0 / fden:.3g} and {h * fc / fden:.3g}, which its q31 "
                              "coefficients cannot hold (each in [2^-32, 1)): with the "
                              f"sample period {h!r} s, Tf must be within about h / 46,000 "
                              "and 92,000 h, or 0 (no filter); or export in float") from None
    try:
        pole = coefficient("ad", ad, "N", n)
    except ConfigError:
        if ad > 0.5:  # within a mantissa's step of 1: N names it
            raise
        # Td far below N h: name what the user set, not N
        raise ConfigError(f"{p}kd", kd, f"gives the derivative filter's pole Td / (Td + N "
                          f"h) = {ad:.3g} (Td = kd / kp, N = {n!r}, h = {h!r}), below what "
                          f"a {real} coefficient holds: a derivative filtered this little is "
                          "not one; set kd 0 (no derivative), a smaller N, or export in "
                          "float") from None
    return FixedPid(
        sc,
        coefficient("b", float(cp[pid.B]), "b", float(cp[pid.B])),
        coefficient("c", float(cp[pid.C]), "c", float(cp[pid.C])),
        coefficient("kp", kp * ratio, "kp", kp),
        coefficient("kih", kih * ratio * guard, "ki", ki),
        coefficient("htt", htt * guard, "Tt", tt),
        pole, coefficient("bd", bd * ratio, "kd", kd), derivative, fa, fb)


#: the PID's coefficients, in the order of its parameter struct: (member, what it is)
_COEFFICIENTS = (
    ("b", "setpoint weight of the proportional term"),
    ("c", "setpoint weight of the derivative"),
    ("kp", "kp * @PU@_Y_SCALE / @PU@_U_SCALE"),
    ("kih", "ki * h * @PU@_Y_SCALE / @PU@_U_SCALE * 2^@F@ (h the sample period)"),
    ("htt", "h / Tt * 2^@F@, >= 0 (0: no tracking, only with kih 0)"),
    ("ad", "the derivative filter's pole Td / (Td + N h), in [0, 1)"),
    ("bd", "kp Td N / (Td + N h) * @PU@_Y_SCALE / @PU@_U_SCALE, of kp's sign or 0"),
    ("fa", "the measurement filter's 1 / (1 + 2 h / Tf + 2 (h / Tf)^2), in (0, 1);\n"
     "        * 0 with fb for no filter"),
    ("fb", "and 2 (h / Tf)^2 fa, in (0, 1), fa + fb < 1"),
)
#: what each coefficient multiplies, which sets the range of shifts the C takes
_KIND = {"b": "gain", "c": "gain", "kp": "gain", "bd": "gain", "kih": "integral",
         "htt": "integral", "ad": "pole", "fa": "filter", "fb": "filter"}
#: per word and kind: ((lowest shift, highest), the mantissa's bits). A code times a
#: coefficient is formed in the word's product type and shifted right by at least 1 (the
#: half of the rounding must fit); q15's integral products, added in 64 bits, may also
#: shift left (kih and h / Tt at 2^24 pass 2^14 at ordinary gains); a pole is below 1; the
#: filter runs in 64 bits with q31 coefficients in both words.
_KINDS = {
    "q31": {"gain": ((1, 62), 31), "integral": ((1, 62), 31), "pole": ((31, 62), 31),
            "filter": ((31, 62), 31)},
    "q15": {"gain": ((1, 30), 15), "integral": ((-24, 30), 15), "pole": ((15, 30), 15),
            "filter": ((31, 62), 31)},
}


def _members(real: str):
    """The tunable parameter struct's coefficients in ``real``: (member, what it is,
    (lowest shift, highest), mantissa bits)."""
    return [(name, text, *_KINDS[real][_KIND[name]]) for name, text in _COEFFICIENTS]


def fixed_params_c(ctrl, key_prefix: str = "", like=None, real: str = "q31") -> str:
    """The C initializer of a tunable fixed-point export's ``PREFIX_params`` for the live
    controller ``ctrl`` (a PID in q31 or q15, or an i-P, i-PI, i-PD or i-PID with the
    backward difference in q31): what ``PREFIX_set_params`` takes to run with its gains.
    ``like``: the controller the export it is sent to was made from (the same law and
    structure), whose formats the coefficients and limits are computed in (default:
    ``ctrl``'s own, from its sample period and input and output limits); ``real``: that
    export's word. The set holds a tag of those formats, and ``PREFIX_set_params``
    refuses a set made for others.

    Examples
    --------
    >>> import mfcontrol
    >>> from mfcontrol.cexport.fixed_point import fixed_params_c
    >>> ctrl = mfcontrol.PID(kp=0.3, ki=0.5, sample_time=0.001, output_limits=(-24, 24),
    ...                      input_limits=(-10, 200))
    >>> print(fixed_params_c(ctrl).splitlines()[4])
        {1342177280L, 32}, /* kp */

    The same gains with narrower output limits, for that export:

    >>> narrow = mfcontrol.PID(kp=0.3, ki=0.5, sample_time=0.001, output_limits=(-12, 12))
    >>> print(fixed_params_c(narrow, like=ctrl).splitlines()[-3])
        -67108864L, /* out_min */

    For a q15 export (15-bit mantissas, codes of 16 bits):

    >>> print(fixed_params_c(ctrl, real="q15").splitlines()[4])
        {20480L, 14}, /* kp */
    """
    from ..api.model.controllers import PID

    if real not in WORDS:
        raise ConfigError("real", real, f"must be one of {', '.join(WORDS)}")
    if not isinstance(ctrl, PID):  # the i-P family's
        if real != "q31":
            raise ConfigError("real", real, "must be q31 for the i-P family (q15 exports "
                              "the PID)")
        from .fixed_point_intelligent import q31_intelligent_params_c

        return q31_intelligent_params_c(ctrl, key_prefix, like)
    q = fixed_pid(ctrl, key_prefix, like, real)
    return params_c(_format("pid", ctrl, q.scales),
                    [(name, getattr(q, name)) for name, _ in _COEFFICIENTS],
                    q.scales.u_limits)


def _format(law: str, ctrl, sc: Scales) -> int:
    """The tag of the formats a q31 law's coefficients are computed for: the law and its
    structure (``law``), its scales, the guard bits and the sample period (a CRC-32)."""
    word = "" if sc.word.name == "q31" else f" {sc.word.name}"  # (q31's tags as they were)
    return zlib.crc32(f"{law} {sc.y_scale!r} {sc.u_scale!r} {GUARD_BITS} "
                      f"{ctrl.sample_time!r}{word}".encode())


def pid_source(ctrl, *, prefix: str, banner: str, key_prefix: str = "",
               frozen: bool = False, real: str = "q31") -> tuple[str, str]:
    """(header, source) of the fixed-point PID of ``ctrl`` (``real``: q31 or q15): its
    coefficients and output limits in a parameter struct that ``PREFIX_set_params`` checks
    and changes at run time, or constants with ``frozen``."""
    q = fixed_pid(ctrl, key_prefix, real=real)
    coefficients = [(name.upper(), getattr(q, name)) for name, _ in _COEFFICIENTS]
    PU = prefix.upper()
    # the filter's code only in an export with a filter (about 1.5 KB on a Cortex-M0): a
    # tunable one may retune it, or switch it off and on; one without refuses it
    filtered = q.fb.mantissa != 0
    filter_parts = {"FILTER_STATE": _FILTER_STATE, "FILTER_START": _FILTER_START,
                    "FILTER_INIT": "    s->yf = 0;\n    s->yw = 0;\n",
                    "FILTER_DEFINES": _FILTER_DEFINES, "FILTER_HELPERS": _FILTER_HELPERS}
    filter_parts = {key: text if filtered else "" for key, text in filter_parts.items()}
    filter_parts["FILTER_HELPERS"] = _fill(filter_parts["FILTER_HELPERS"], {"BITS": BITS})
    if frozen:
        subs = {name: f"{PU}_{name}_M, {PU}_{name}_S" for name, _ in coefficients}
        weighted = q.c.mantissa != 0
        derivative = ("    {  /* the derivative */\n        @PROD@ de = "
                      + (_WEIGHTED.replace("\n ", "\n     ") if weighted else _PLAIN)
                      + ";\n" + _D_STEP + "    }\n") if q.derivative else ""
        subs |= {"DERIVATIVE": derivative, "OVER_GAP": _OVER_GAP if q.derivative else "",
                 "FILTER": _FILTER if filtered else "",
                 "AT": _AT if q.derivative or filtered else "",
                 "ULIM": f"{PU}_U_LO, {PU}_U_HI", "MUL": _MUL[True]}
        subs |= filter_parts
        subs |= dict.fromkeys(TUNABLE_PARTS, "")
    else:
        subs = {name: f"s->params.{name.lower()}.m, s->params.{name.lower()}.s"
                for name, _ in coefficients}
        subs |= {"DERIVATIVE": _fill(_DERIVATIVE, {"WEIGHTED": _WEIGHTED, "PLAIN": _PLAIN,
                                                   "D_STEP": _D_STEP}),
                 "OVER_GAP": _OVER_GAP, "AT": _AT,
                 # run only where the parameters have a filter
                 "FILTER": "    if (s->params.fb.m != 0) " + _FILTER.lstrip()
                 if filtered else "",
                 "ULIM": "s->params.out_min, s->params.out_max", "MUL": _MUL[False]}
        subs |= filter_parts
        subs |= tunable_parts(prefix, _members(real),
                              fixed_params_c(ctrl, key_prefix, real=real),
                              _format("pid", ctrl, q.scales), "the PID's coefficients",
                              _PID_CHECKS if filtered else _PID_CHECKS_NO_FILTER,
                              _PID_APPLY)
    # the integral's products: q15's may shift left (its coefficients' range, _KINDS)
    subs |= ({"IMUL": "@P@_mul", "IMUL_HELPER": ""} if real == "q31" else
             {"IMUL": "@P@_imul", "IMUL_HELPER": _IMUL_Q15})
    # the pieces first: the coefficients' names in them are filled after
    subs = {key: subs[key] for key in ("DERIVATIVE", "OVER_GAP", "FILTER")} | subs
    # the tunable build's coefficients are its default parameter set's, not constants
    return q31_files(ctrl, q.scales, coefficients if frozen else [], prefix=prefix,
                     banner=banner, templates=(_HEADER, _SOURCE), subs=subs)


def q31_files(ctrl, sc: Scales, coefficients, *, prefix: str, banner: str,
              templates: tuple[str, str], subs: dict[str, str]) -> tuple[str, str]:
    """(header, source) of a fixed-point law from its templates: their shared opening
    lines (``@Q31_HEAD@``, ``@Q31_TAIL@`` in the header, ``@Q31_PRELUDE@`` in the source:
    the formats, the modes, the coefficients ``(NAME, Coefficient)`` as
    ``PREFIX_NAME_M`` and ``PREFIX_NAME_S``) and the law's own ``subs`` filled in."""
    PU = prefix.upper()
    consts = "".join(f"#define {PU}_{name}_M ({c.mantissa}L)\n#define {PU}_{name}_S {c.shift}\n"
                     for name, c in coefficients)
    if consts:
        consts = ("/* the coefficients, M * 2^-S with |M| in [2^(B-1), 2^B), or 0 (B the bits "
                  "of its\n * mantissa: 31, or 15 for a q15 law's own; "
                  "mfcontrol.cexport.fixed_point) */\n" + consts)
    word = sc.word
    every = {"Q31_HEAD": _Q31_HEAD, "Q31_TAIL": _Q31_TAIL, "Q31_PRELUDE": _Q31_PRELUDE,
             **subs, "P": prefix, "PU": PU, "CONSTS": consts, "BANNER": banner,
             "Q": word.name, "QBITS": str(word.bits), "CODE": word.code, "PROD": word.product,
             "CODE_MAX": word.code_max, "RESULT": str(2 * word.bits - 1),
             "YLO": str(sc.y_limits[0]), "YHI": str(sc.y_limits[1]),
             "ULO": str(sc.u_limits[0]), "UHI": str(sc.u_limits[1]),
             "YS": repr(sc.y_scale), "US": repr(sc.u_scale), "DT": repr(ctrl.sample_time),
             "F": str(GUARD_BITS)}
    header, source = (_fill(text, every) for text in templates)
    left = re.search(r"@[A-Z0-9_]+@", header + source)
    if left:  # a template's name nothing filled: a bug here, not the user's
        raise AssertionError(f"unfilled {left[0]} in the q31 export")
    return header, source


#: the fixed-point headers' opening lines: the formats, the sample period and the modes
_Q31_HEAD = """@BANNER@
#ifndef MFCONTROL_@P@_H
#define MFCONTROL_@P@_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* @Q@ codes (@CODE@): a measurement or a setpoint y (physical units) is the code
 * Y = round(y * 2^@QBITS@ / @PU@_Y_SCALE), the output code U is u = U * @PU@_U_SCALE / 2^@QBITS@;
 * a code is within +-(2^@QBITS@ - 1). The scales (and the period) are double constants for
 * the host or for conversions the compiler folds: on a core without an FPU, convert at
 * run time with integers (a reading's counts per code), not with them. */
typedef @CODE@ @P@_@Q@;
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
typedef char @P@_arithmetic_shift[((int64_t)-1 >> 1) == (int64_t)-1 ? 1 : -1];

@CONSTS@#define @PU@_Y_LO (@YLO@L)
#define @PU@_Y_HI (@YHI@L)
#define @PU@_F @F@
/* a state passed to @P@_init: its mode is one of the two */
#define @PU@_INITIALISED(s) ((s)->mode == @PU@_AUTO || (s)->mode == @PU@_MANUAL)
"""


_HEADER = """@Q31_HEAD@@PARAMS@
typedef struct {
@STATE_PARAMS@    int64_t i;              /* the integral, in output codes * 2^@F@ */
    @P@_@Q@ d;              /* the derivative term, output codes */
@FILTER_STATE@    @P@_@Q@ y_old, r_old;   /* the last sample's (filtered) measurement, setpoint */
    @P@_@Q@ start;          /* the output the next sample is set to give (bumpless) */
    @P@_@Q@ last_output;    /* returned in manual mode and after a rejected sample */
    unsigned long nan_count; /* rejected: a measurement outside the input limits */
    int skipped;            /* samples rejected since the last one taken (up to
                             * @PU@_SKIP_MAX): the next step spans them */
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
@P@_@Q@ @P@_step(@P@_state *s, @P@_@Q@ y, @P@_@Q@ setpoint);
/* Manual mode: every step returns u, clamped to the output limits, until @P@_set_auto. */
void @P@_set_manual(@P@_state *s, @P@_@Q@ u);
/* Back to automatic, restarting the law from the last output (bumpless while the
 * integral that gives it, last output - P - D, is within 2^37 output codes, far beyond
 * the output's scale; beyond, at extreme gains, it saturates there). */
void @P@_set_auto(@P@_state *s);
@SET_PARAMS_DECL@@Q31_TAIL@"""

#: the derivative over a gap of periods (only where the step has a derivative)
_OVER_GAP = """/* The derivative over d periods (d in [2, 256]) from its value x over one:
 * ad' = Td / (Td + N d h) and bd' = kp Td N / (Td + N d h) are ad and bd divided by
 * D = 1 + (d - 1)(1 - ad), so x / D rounded to nearest. ad = m 2^-s (s >= @QBITS@) rounded to
 * 2^-31 gives D 2^31 below 2^39, taken to 2^-23 (>> 8, D >= 1) so that x 2^23 fits 63
 * bits once x is within +-2^39 (beyond, x / D >= 2^39 / 256 saturates an int32 all the
 * same). On the step after rejected samples only: a 64-bit division. */
static int64_t @P@_over_gap(int64_t x, int d, int32_t m, int shift)
{
    int64_t a = @P@_at(m, shift, 31);
    int64_t den = (((int64_t)1 << 31) + (d - 1) * (((int64_t)1 << 31) - a)) >> 8;
    int64_t num;
    if (x > ((int64_t)1 << 39)) x = (int64_t)1 << 39;
    if (x < -((int64_t)1 << 39)) x = -((int64_t)1 << 39);
    num = x * ((int64_t)1 << 23);
    return num >= 0 ? (num + den / 2) / den : -((-num + den / 2) / den);
}

"""

#: a coefficient at another scale (the steps over a gap of periods take their
#: coefficients so)
_AT = """\
/* x 2^-s at the scale 2^-k, x 2^(k - s) (x >= 0): exact for s <= k, rounded to nearest for
 * s > k (a coefficient m 2^-s below 1 rounded to 2^-31 is at(m, s, 31)) */
static int64_t @P@_at(int64_t x, int s, int k)
{
    return s == k ? x : s < k ? x << (k - s) : (((x >> (s - k - 1)) + 1) >> 1);
}

"""

#: the bit length of a non-negative integer (the i-P family's step over a gap takes it too)
BITS = """\
/* the number of bits of x >= 0: a binary search (a loop of 64-bit shifts costs a
 * Cortex-M0 hundreds of instructions) */
static int @P@_bits(int64_t x)
{
    int n = 0;
    if (x >> 32) { n += 32; x >>= 32; }
    if (x >> 16) { n += 16; x >>= 16; }
    if (x >> 8) { n += 8; x >>= 8; }
    if (x >> 4) { n += 4; x >>= 4; }
    if (x >> 2) { n += 2; x >>= 2; }
    if (x >> 1) { n += 1; x >>= 1; }
    return n + (int)x;
}

"""

#: the measurement filter's arithmetic (where the step has a filter)
_FILTER_HELPERS = """\
/* x * M * 2^-s rounded to nearest, ties up, for |x| <= 2^57, |M| <= 2^31 and s in
 * [31, 62] (a filter coefficient, at most 1): x = hi 2^31 + lo (0 <= lo < 2^31) and
 * lo M = bh 2^31 + bl (0 <= bl < 2^31), so x M = t 2^31 + bl, t = hi M + bh, |t| < 2^58:
 * no product overflows */
static int64_t @P@_fmul(int64_t x, int64_t m, int shift)
{
    int64_t hi = x >> 31;
    int64_t lo = x - hi * ((int64_t)1 << 31);
    int64_t b = lo * m;
    int64_t bh = b >> 31;
    int64_t t = hi * m + bh;
    int64_t bl = b - bh * ((int64_t)1 << 31);
    return (t + ((bl + ((int64_t)1 << (shift - 1))) >> 31)) >> (shift - 31);
}

@BITS@/* p 2^-s (0 <= p < 2^63) as a coefficient m 2^-shift the products take: m <= 2^31 and
 * shift in [31, 62], rounded (below 2^-31 it keeps fewer bits of mantissa, an absolute
 * error under 2^-63) */
static int64_t @P@_coef_of(int64_t p, int s, int *shift)
{
    int k = @P@_bits(p >> 31);  /* the least k with p / 2^k below 2^31 */
    int64_t m;
    if (s - k > 62) k = s - 62;
    m = k > 0 ? ((p >> (k - 1)) + 1) >> 1 : p;
    if (s - k < 31) {  /* 1 itself, from rounding: the same value at shift 31 */
        m >>= 31 - (s - k);
        k = s - 31;
    }
    *shift = s - k;
    return m;
}

/* The filter's coefficients over d periods (d in [2, 256]): its step at d h,
 * w = (fa w + d fb e) / Q with Q = 1 + (d - 1)(1 - fa + d fb), is w = alpha w + beta e with
 * alpha = fa / Q and beta = d fb / Q, both below 1. Q 2^46 from fa and fb's full mantissas
 * (below 2^63), its reciprocal to 31 bits from one 64-bit division, and alpha and beta
 * to about 2^-29 relative however small fb is (a slow filter's). On the step after
 * rejected samples only. */
static void @P@_filter_gap(int d, int32_t am, int as, int32_t bm, int bs, int64_t *alpha,
                           int *alpha_s, int64_t *beta, int *beta_s)
{
    int64_t fa = @P@_at(am, as, 46);
    int64_t fb = @P@_at((int64_t)(d - 1) * d * bm, bs, 46);  /* (d - 1) d fb, below 2^47 2^-bs */
    int64_t q = ((int64_t)1 << 46) + (d - 1) * (((int64_t)1 << 46) - fa) + fb;
    int z = @P@_bits(q >> 32);  /* q / 2^z below 2^32 */
    int64_t inv;
    inv = (((int64_t)1 << 62) + (q >> z) / 2) / (q >> z);  /* 2^(62 - z) 2^46 / Q */
    *alpha = @P@_coef_of(am * inv, as + 16 + z, alpha_s);
    *beta = @P@_coef_of(((bm * inv) >> 8) * d, bs + 8 + z, beta_s);
}

"""

#: the measurement filter's step: y becomes the filtered measurement's code
_FILTER = """\
    {  /* the measurement filter (y * 2^F, in 64 bits): y becomes its filtered code */
        int64_t e = (int64_t)y * ((int64_t)1 << @PU@_F) - s->yf;
        int64_t w;
        if (gap == 1) {  /* (its coefficients' own products: with constants, the cheaper) */
            w = @P@_fmul(s->yw, @FA@) + @P@_fmul(e, @FB@);
        } else {  /* one step over the gap, as the double law takes it */
            int64_t alpha, beta;
            int alpha_s, beta_s;
            @P@_filter_gap(gap, @FA@, @FB@, &alpha, &alpha_s, &beta, &beta_s);
            w = @P@_fmul(s->yw, alpha, alpha_s) + @P@_fmul(e, beta, beta_s);
        }
        s->yw = @P@_sat_to(w, @PU@_W_MAX);
        s->yf = @P@_sat_to(s->yf + @P@_times(s->yw, gap), @PU@_X_MAX);
        y = @P@_sat_code((s->yf + ((int64_t)1 << (@PU@_F - 1))) >> @PU@_F);
    }
"""
_FILTER_STATE = """\
    int64_t yf;             /* the filtered measurement, input codes * 2^@F@ */
    int64_t yw;             /* its increment over the last period, the same units */
"""
_FILTER_START = """\
        s->yf = (int64_t)y * ((int64_t)1 << @PU@_F); /* at rest at the first one */
        s->yw = 0;
"""
_FILTER_DEFINES = """\
/* the filter's bounds, input codes * 2^F: its value (a code's), its increment */
#define @PU@_X_MAX ((int64_t)1 << (31 + @PU@_F))
#define @PU@_W_MAX ((int64_t)1 << (32 + @PU@_F))
"""

#: the step's derivative: in the tunable build, tested at run time (a derivative, a
#: setpoint weight); in the frozen build, written out only where the export has them
_DERIVATIVE = """\
    if (s->params.ad.m != 0 || s->params.bd.m != 0) {  /* a derivative */
        @PROD@ de;
        if (s->params.c.m != 0)  /* its setpoint weight */
            de = @WEIGHTED@;
        else
            de = @PLAIN@;
@D_STEP@    }
"""
_D_STEP = """\
        d = @P@_mul(s->d, @AD@) - @P@_mul(@P@_sat_code(de), @BD@);
        if (gap > 1) d = @P@_over_gap(d, gap, @AD@);
        d = @P@_sat_code(d);
"""
_WEIGHTED = """(y - @P@_mul(setpoint, @C@))
                 - (s->y_old - @P@_mul(s->r_old, @C@))"""
_PLAIN = "(@PROD@)y - s->y_old"


#: the end of the product's comment and its body: with a constant shift (the frozen
#: build) the half is a constant; with a shift read at run time (the tunable one),
#: floor((a + 2^(S-1)) / 2^S) = floor((floor(a / 2^(S-1)) + 1) / 2) shifts by a variable
#: once where the other form shifts twice (the same codes: an identity of integers;
#: measured on the Cortex-M4F, each form is the cheaper one in its build)
_MUL = {True: """ */
static @PROD@ @P@_mul(@P@_@Q@ x, @PROD@ m, int shift)
{
    return ((@PROD@)x * m + ((@PROD@)1 << (shift - 1))) >> shift;""",
        False: """; the half added as
 * floor((a + 2^(S-1)) / 2^S) = floor((floor(a / 2^(S-1)) + 1) / 2): one shift by the
 * variable S, not two) */
static @PROD@ @P@_mul(@P@_@Q@ x, @PROD@ m, int shift)
{
    return ((((@PROD@)x * m) >> (shift - 1)) + 1) >> 1;"""}


#: q15's products for the integral (its coefficients kih and h / Tt times 2^F pass 2^14 at
#: ordinary gains): a shift S <= 0 multiplies the 32-bit product by 2^-S in 64 bits,
#: exactly (a left shift of a negative number would be undefined behaviour)
_IMUL_Q15 = """
/* x * M * 2^-S for the integral (|x|, |M| < 2^15): as mul for S >= 1; for S in [-24, 0]
 * exactly, the product times 2^-S (below 2^54) */
static int64_t @P@_imul(@P@_q15 x, int32_t m, int shift)
{
    if (shift > 0) return @P@_mul(x, m, shift);
    return (int64_t)(x * m) * ((int64_t)1 << -shift);
}
"""


#: a tunable build's parameter struct and the members of its setter's answer
_PARAMS = """
/* A coefficient: m * 2^-s, with |m| in [2^(B-1), 2^B) or m = 0, B the bits of its
 * mantissa and s in the range @P@_set_params takes for it (both given with each member
 * of @P@_params). */
typedef struct {
    int32_t m;
    int32_t s;
} @P@_coef;

/* the formats a parameter set is computed for (the law, its structure, the scales, the
 * period, F): a set made for another export's is refused */
#define @PU@_FORMAT @FORMAT@

/* The parameters a running controller may change (@P@_set_params), in the codes' units
 * (mfcontrol.cexport.fixed_point): @WHAT@ and the output limits. For new
 * gains, call mfcontrol.cexport.fixed_point.fixed_params_c(ctrl, like=exported,
 * real="@Q@") in Python, or export the case again with them and the same limits and take
 * its @P@_default_params; new output limits are codes, limit / @PU@_U_SCALE * 2^@QBITS@. */
typedef struct {
    uint32_t format; /* @PU@_FORMAT */
@MEMBERS@    @CODE@ out_min;  /* lower output limit, a code */
    @CODE@ out_max;  /* upper output limit, a code, >= out_min */
} @P@_params;

/* what @P@_set_params returns: 0 taken, -1 a state never initialised, or the member at
 * fault */
enum {
@FIELDS@
};

/* the parameters exported: what init starts from */
extern const @P@_params @P@_default_params;
"""

_STATE_PARAMS = """\
    /* the parameters the law runs with (@P@_set_params changes them: do not write them
     * here, where nothing checks them) */
    @P@_params params;
"""

_SET_PARAMS_DECL = """\
/* Change the parameters while running. Every member is checked: a set made for other
 * formats, a coefficient the products cannot take, a limit pair out of order... is
 * refused, nothing changes, and the member at fault is returned (@PU@_FIELD_...).
 * Taken: in automatic mode the law restarts from the last output clamped to the new
 * limits (bumpless, as @P@_set_auto does; before any sample it starts as @P@_init would
 * with them; an unchanged set changes nothing), in manual mode the held output is
 * clamped to the new limits. Returns 0 when taken, -1 for a state never initialised (or
 * no parameters).
 * Call it where @P@_step is called (or with that interrupt masked): the copy is not
 * atomic. */
int @P@_set_params(@P@_state *s, const @P@_params *p);
"""

_SETTER = """
/* the parameters exported: what init starts from */
const @P@_params @P@_default_params = @DEFAULTS@;

/* a coefficient the products take: 0, or |m| in [low, 2 low) (low 2^(B-1), B the bits of
 * its mantissa); its shift in [lo, hi] */
static int @P@_coef_ok(@P@_coef c, int lo, int hi, int32_t low)
{
    if (c.s < lo || c.s > hi) return 0;
    return c.m == 0 || (c.m >= low && c.m - low < low) || (c.m <= -low && -low - c.m < low);
}

int @P@_set_params(@P@_state *s, const @P@_params *p)
{
    if (!@PU@_INITIALISED(s) || !p) return -1;
    if (p->format != @PU@_FORMAT) return @PU@_FIELD_FORMAT;
@CHECKS@    if (p->out_min < -@CODE_MAX@) return @PU@_FIELD_OUT_MIN;
    if (p->out_max < p->out_min) return @PU@_FIELD_OUT_MAX;
    if (@SAME@)
        return 0; /* nothing changes */
    s->params = *p;
@APPLY@    return 0;
}
"""

#: the PID's checks beyond each coefficient's range, and what a set taken does
_PID_CHECKS = {
    "htt": ("h / Tt >= 0; 0 (Tt infinite) only without an integral, whose windup nothing\n"
            "     * would then stop (mfcontrol.PID's rule)",
            "p->htt.m < 0 || (p->htt.m == 0 && p->kih.m != 0)"),
    "ad": ("a pole in [0, 1): a value below 1 has a shift of @QBITS@ or more",
           "p->ad.m < 0 || (p->ad.m != 0 && p->ad.s < @QBITS@)"),
    "bd": ("kd of kp's sign, or 0",
           "(p->bd.m > 0 && p->kp.m <= 0) || (p->bd.m < 0 && p->kp.m >= 0)"),
    "fa": ("the filter's fa > 0 with fb, 0 with it (no filter)",
           "p->fa.m < 0 || (p->fa.m == 0) != (p->fb.m == 0)"),
    "fb": ("fb >= 0 and fa + fb < 1 (a filter of positive time constants)",
           "p->fb.m < 0 ||\n        (p->fb.m != 0 && @P@_at(p->fa.m, p->fa.s, 31) + "
           "@P@_at(p->fb.m, p->fb.s, 31) >= ((int64_t)1 << 31))"),
}
#: and in an export without a measurement filter (no code to run one)
_PID_CHECKS_NO_FILTER = {key: value for key, value in _PID_CHECKS.items() if key != "fb"} | {
    "fa": ("no measurement filter in this export (made with Tf 0): fa and fb 0",
           "p->fa.m != 0 || p->fb.m != 0")}
_PID_APPLY = """\
    if (s->mode != @PU@_MANUAL && !s->started && !s->pending) {
        s->last_output = @P@_clamp(0, p->out_min, p->out_max); /* before any sample: as init */
    } else { /* the output held (in manual mode, or after a rejected sample), within the
              * new limits; in automatic mode the law restarts from it */
        s->last_output = @P@_clamp(s->last_output, p->out_min, p->out_max);
        if (s->mode != @PU@_MANUAL) @P@_restart(s);
    }
"""


#: the pieces :func:`tunable_parts` fills (empty in a frozen build)
TUNABLE_PARTS = ("PARAMS", "STATE_PARAMS", "SET_PARAMS_DECL", "SETTER", "INIT_PARAMS")


def tunable_parts(prefix: str, members, defaults: str, tag: int, what: str,
                  extra: dict[str, tuple[str, str]], apply: str) -> dict[str, str]:
    """The pieces of a tunable q31 build (``PARAMS``, ``STATE_PARAMS``,
    ``SET_PARAMS_DECL``, ``SETTER``, ``INIT_PARAMS``): ``members`` the coefficients'
    ``(name, what, (lowest shift, highest), mantissa bits)``, ``defaults`` the exported set's
    initializer, ``tag`` its formats' (:func:`_format`), ``what`` the struct's words for
    them, ``extra`` a member's condition of refusal beyond its range (a comment, the C
    condition), ``apply`` what a set taken does after the copy."""
    PU = prefix.upper()
    fields = ["format", *(name for name, _, _, _ in members), "out_min", "out_max"]
    checks = "".join(
        (f"    /* {extra[name][0]} */\n" if name in extra else "")
        + f"    if (!{prefix}_coef_ok(p->{name}, {lo}, {hi}, 0x{2 ** (bits - 1):X}L)"
        + (f" ||\n        {extra[name][1]})" if name in extra else ")")
        + f"\n        return {PU}_FIELD_{name.upper()};\n"
        for name, _, (lo, hi), bits in members)
    same = " &&\n        ".join(
        [f"p->{f} == s->params.{f}" for f in ("format", "out_min", "out_max")]
        + [f"p->{f}.m == s->params.{f}.m && p->{f}.s == s->params.{f}.s"
           for f, _, _, _ in members])
    return {
        "PARAMS": _fill(_PARAMS, {
            "MEMBERS": "".join(f"    {prefix}_coef {name}; /* {text};\n"
                               f"        * m of {bits} bits, s in [{lo}, {hi}] */\n"
                               for name, text, (lo, hi), bits in members),
            "FORMAT": f"0x{tag:08X}UL", "WHAT": what,
            "FIELDS": ",\n".join(f"    {PU}_FIELD_{f.upper()} = {k}"
                                 for k, f in enumerate(fields, 1))}),
        "STATE_PARAMS": _STATE_PARAMS, "SET_PARAMS_DECL": _SET_PARAMS_DECL,
        "SETTER": _fill(_SETTER, {"DEFAULTS": defaults, "CHECKS": checks, "SAME": same,
                                  "APPLY": apply}),
        "INIT_PARAMS": f"    s->params = {prefix}_default_params;\n"}


def params_c(tag: int, coefficients, limits: tuple[int, int]) -> str:
    """The C initializer of a q31 parameter set: the formats' ``tag``, the
    ``(name, Coefficient)`` pairs and the output limits' codes."""
    lo, hi = limits
    return ("{\n" + f"    0x{tag:08X}UL, /* format */\n"
            + "".join(f"    {{{c.mantissa}L, {c.shift}}}, /* {name} */\n"
                      for name, c in coefficients)
            + f"    {lo}L, /* out_min */\n    {hi}L /* out_max */\n}}")


_SOURCE = """@Q31_PRELUDE@#define @PU@_U_LO (@ULO@L)
#define @PU@_U_HI (@UHI@L)
#define @PU@_I_MAX ((int64_t)1 << 61)
#define @PU@_T_MAX ((int64_t)1 << (61 - @PU@_F))
/* rejected samples in a row a step spans at most (a longer gap counts as this one) */
#define @PU@_SKIP_MAX 255
@FILTER_DEFINES@
/* x saturated to a code, +-@CODE_MAX@ */
static @P@_@Q@ @P@_sat_code(int64_t x)
{
    if (x > @CODE_MAX@) return @CODE_MAX@;
    if (x < -@CODE_MAX@) return -@CODE_MAX@;
    return (@P@_@Q@)x;
}

/* x saturated to +-bound: the integral to I_MAX (it and two products, each below 2^61,
 * sum without overflow), the filter's values to theirs */
static int64_t @P@_sat_to(int64_t x, int64_t bound)
{
    return x > bound ? bound : (x < -bound ? -bound : x);
}

/* x * M * 2^-S, rounded to nearest, ties up (|x| < 2^@QBITS@, |M| < 2^@QBITS@, S >= 1: the
 * product and the half fit @PROD@, and the result is below 2^@RESULT@)@MUL@
}
@IMUL_HELPER@
/* x * d saturated to +-I_MAX (|x| < 2^61, d in [1, 256]): an increment over d periods.
 * Within +-2^53 it cannot saturate (d <= 2^8): the 64-bit divisions that find where it
 * would (a library call each on a Cortex-M) only beyond, and no product for d = 1 (the
 * filter's every step) */
static int64_t @P@_times(int64_t x, int d)
{
    if (d == 1) return x;
    if (x > ((int64_t)1 << 53) || x < -((int64_t)1 << 53)) {
        if (x > @PU@_I_MAX / d) return @PU@_I_MAX;
        if (x < -@PU@_I_MAX / d) return -@PU@_I_MAX;
    }
    return x * d;
}

@AT@@FILTER_HELPERS@@OVER_GAP@static @P@_@Q@ @P@_clamp(int64_t v, @P@_@Q@ lo, @P@_@Q@ hi)
{
    return (@P@_@Q@)(v > hi ? hi : (v < lo ? lo : v));
}

void @P@_init(@P@_state *s)
{
    s->i = 0;
    s->d = 0;
@FILTER_INIT@    s->y_old = 0;
    s->r_old = 0;
    s->start = 0;
@INIT_PARAMS@    s->last_output = @P@_clamp(0, @ULIM@);
    s->nan_count = 0;
    s->skipped = 0;
    s->started = 0;
    s->pending = 0;
    s->mode = @PU@_AUTO;
}

@P@_@Q@ @P@_step(@P@_state *s, @P@_@Q@ y, @P@_@Q@ setpoint)
{
    int64_t p, d = 0, v;
    @P@_@Q@ u;
    int gap;
    if (s->mode != @PU@_AUTO) /* manual; or never initialised: within the limits, unchanged */
        return s->mode == @PU@_MANUAL ? s->last_output : @P@_clamp(0, @PU@_U_LO, @PU@_U_HI);
    if (y < @PU@_Y_LO || y > @PU@_Y_HI) {
        s->nan_count++;
        if (s->skipped < @PU@_SKIP_MAX) s->skipped++;
        return s->last_output;
    }
    gap = s->skipped + 1; /* the period since the last sample taken, in periods */
    s->skipped = 0;
    if (!s->started) {
        s->y_old = y;
        s->r_old = setpoint;
@FILTER_START@    }
@FILTER@    p = @P@_mul(@P@_sat_code(@P@_mul(setpoint, @B@) - y), @KP@);
@DERIVATIVE@    if (s->pending) {  /* the bumpless start: the integral that gives `start` */
        int64_t t = (int64_t)s->start - p - d;
        if (t > @PU@_T_MAX) t = @PU@_T_MAX;
        if (t < -@PU@_T_MAX) t = -@PU@_T_MAX;
        s->i = t * ((int64_t)1 << @PU@_F);
        s->pending = 0;
    }
    v = p + ((s->i + ((int64_t)1 << (@PU@_F - 1))) >> @PU@_F) + d;
    u = @P@_clamp(v, @ULIM@);
    {
        /* ki h e and h / Tt (u - v), over the periods since the last sample taken */
        int64_t ie = @IMUL@(@P@_sat_code((int64_t)setpoint - y), @KIH@);
        int64_t it = @IMUL@(@P@_sat_code((int64_t)u - v), @HTT@);
        if (gap > 1) {
            ie = @P@_times(ie, gap);
            it = @P@_times(it, gap);
        }
        s->i = @P@_sat_to(s->i + ie + it, @PU@_I_MAX);
    }
    s->d = (@P@_@Q@)d;
    s->y_old = y;
    s->r_old = setpoint;
    s->started = 1;
    s->last_output = u;
    return u;
}

void @P@_set_manual(@P@_state *s, @P@_@Q@ u)
{
    if (!@PU@_INITIALISED(s)) return;
    s->mode = @PU@_MANUAL;
    s->last_output = @P@_clamp(u, @ULIM@);
}

/* restart the law from the last output (bumpless), as the live PID's reset does */
static void @P@_restart(@P@_state *s)
{
    s->i = 0;
    s->d = 0;
    s->skipped = 0;
    s->started = 0;
    s->start = s->last_output;
    s->pending = 1;
}

void @P@_set_auto(@P@_state *s)
{
    if (!@PU@_INITIALISED(s)) return;
    if (s->mode == @PU@_MANUAL) @P@_restart(s); /* from manual */
    s->mode = @PU@_AUTO;
}
@SETTER@"""
