"""A live controller as a C99 header and source file.

The law is translated from :mod:`mfcontrol.laws` (:mod:`mfcontrol.cexport.translate`); this
module adds what the live controller of :mod:`mfcontrol.api.model.controllers` adds around it:
the measurement guard (a NaN or infinite measurement, or one outside the input limits,
returns the last output and is counted; so is a step that overflows, whose output or
memory is not finite, which leaves the memory as it was; the second such step in a row
restarts the law from its last output), the manual mode with its bumpless return to
automatic, and the parameter table baked in.
"""

from __future__ import annotations

import functools
import inspect
import math
import re
import textwrap
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._version import __version__
from ..api.model.controllers import ADRC, PID, RESTART_AFTER, IntelligentController, RecursiveIP
from ..errors import ConfigError
from ..laws import adrc, estimators, intelligent, pid, recursive_ip
from ..laws import variational_gain as gain_law
from .translate import _C_KEYWORDS, CP, CS, REAL, J, Options, Translator

REALS = ("double", "float", "q31", "q15")
#: how to compile an export so that, in double, it computes what mfcontrol computes: no
#: contraction of a multiply and an add into one rounding (and no -ffast-math)
CFLAGS = ("-std=c99", "-O2", "-ffp-contract=off")
_LONG_MAX = 2**31 - 1  # the least a C long holds
_FLOAT_EXACT = 2**24  # integers a float holds exactly


def _largest_window(fits) -> int:
    M = 2
    while fits(M + 1):
        M += 1 if M < 1000 else max(1, M // 1000)
    while not fits(M):
        M -= 1
    return M


#: The algebraic estimator's sample count wraps by M (M + 1) and stays below M (M + 2)
#: (:func:`mfcontrol.laws.estimators.push`). Its largest intermediate, count + M + 1,
#: must fit in a C long (32 bits at least); in a float export the count itself must be an
#: exact float.
MAX_WINDOW = {
    "double": _largest_window(lambda M: M * (M + 3) + 1 <= _LONG_MAX),
    "float": _largest_window(lambda M: M * (M + 2) <= _FLOAT_EXACT),
}
_FLOAT = np.finfo(np.float32)


@dataclass
class CSource:
    """The exported files' text: ``header`` (``PREFIX.h``) and ``source`` (``PREFIX.c``)."""

    prefix: str
    real: str
    header: str
    source: str
    law: str  # the law family: "intelligent", "recursive", "pid" or "adrc"
    n_state: int
    #: the members of ``PREFIX_params`` in physical units, in order (empty for a frozen
    #: export, and for the fixed-point ones, whose members are coefficients in the codes'
    #: units)
    fields: tuple[str, ...] = ()


def check_prefix(prefix: str) -> str:
    if not isinstance(prefix, str) or not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]{0,30}", prefix):
        raise ConfigError("prefix", prefix, "must be a C identifier of 1 to 31 letters, "
                          "digits and underscores, starting with a letter")
    return prefix


#: a live controller's keywords as a case names them
_CASE_KEYS = {"sample_time": "sim.h", ("output_limits", 0): "controller.duty_min",
              ("output_limits", 1): "controller.duty_max"}


def _parameter_named(ctrl, value: float, key_prefix: str) -> tuple[str, object, str]:
    """(keyword, the value given, "" or "1/") of the controller keyword that gave a
    parameter row ``value`` directly or as its reciprocal, for a message; with
    ``key_prefix`` (a case) the case's key."""
    for key, given in ctrl._params.items():
        items = list(enumerate(given)) if isinstance(given, list) else [(None, given)]
        for i, v in items:
            if isinstance(v, int | float) and not isinstance(v, bool) and v:
                inverse = "" if v == value else ("1/" if 1.0 / v == value else None)
                if inverse is None:
                    continue
                if not key_prefix:
                    return key, given, inverse
                name = _CASE_KEYS.get(key if i is None else (key, i), f"{key_prefix}{key}")
                return name, v, inverse
    return "parameter", value, ""


def _check_float_range(ctrl, cp, key_prefix: str) -> None:
    dt = ctrl.sample_time
    for v in [*cp, *([] if dt is None else [dt])]:
        if math.isfinite(v) and v != 0.0 and not _FLOAT.tiny <= abs(v) <= _FLOAT.max:
            key, given, inverse = _parameter_named(ctrl, float(v), key_prefix)
            what = f"1/{key.split('.')[-1]} = {v:.3g}" if inverse else "it"
            raise ConfigError(key, given, f"{what} is outside the range of a normal float "
                              f"({_FLOAT.tiny:.3g} to {_FLOAT.max:.3g} in magnitude): "
                              "export in double")


def c_source(ctrl, *, prefix: str = "mfc", real: str = "double", description: str = "",
             key_prefix: str = "", frozen: bool = False) -> CSource:
    """Translate a live controller (``IP``, ``IPI``, ``IPD``, ``IPID``, ``PID``, ``ADRC``
    or ``RecursiveIP``) into C99. The C starts as the controller would if built afresh with
    its parameters (a manual/automatic switch the object went through is not exported).

    The law's tunable rows (:mod:`mfcontrol.laws.tunable`: gains, limits) are members of
    a parameter struct in the state, which ``PREFIX_set_params`` checks and changes at run
    time; the rows that fix the law's structure are constants the compiler folds. With
    ``frozen`` every row is a constant and there is no setter.

    ``description`` goes into the files' leading comment (the case it came from);
    ``key_prefix`` (``"controller."`` for a case) goes before a keyword an error names."""
    check_prefix(prefix)
    if real not in REALS:
        raise ConfigError("real", real, f"must be one of {', '.join(REALS)}")
    if real in ("q31", "q15"):
        return _fixed(ctrl, prefix, description, key_prefix, frozen, real)
    law = law_of(ctrl, real, key_prefix)  # refuses what cannot export
    if isinstance(ctrl, RecursiveIP):
        # the parameters as built: a bumpless start rewrites the law's u0 in place
        ctrl = RecursiveIP(**ctrl._params)
    cp = ctrl._CP[:, 0]
    if real == "float":
        _check_float_range(ctrl, cp, key_prefix)
    table = f"{prefix}_fixed"
    tunable = () if frozen else law.module.tunable(cp)
    fields = None if frozen else {row: name for name, row, _ in tunable}
    options = Options(prefix, real, table, law.state_rows, law.replace, fields)
    tr = Translator(options)
    coef = None if law.coefficients is None else tr.function(law.coefficients, (CP, J, REAL))
    n_coef = 0 if coef is None or coef.returns is None else len(coef.returns)
    step = tr.function(law.step, law.step_kinds + (REAL,) * n_coef)
    reset = tr.function(law.reset, law.reset_kinds)
    roots = [step, reset] + ([] if coef is None else [coef])
    if not frozen:
        invalid = tr.function(law.module.invalid_row, (CP, J))
        roots.append(invalid)
    n_cs = ctrl._CS.shape[0] + len(law.state_rows) + law.extra_rows
    dt = ctrl.sample_time
    lo, hi = ctrl.input_limits
    in_range = "".join(f" || y {op} {options.literal(v)}"
                       for op, v in (("<", lo), (">", hi)) if v is not None)
    subs = {
        "P": prefix, "R": f"{prefix}_real", "NS": str(n_cs),
        "PU": prefix.upper(), "RESTART": str(RESTART_AFTER), "RANGE": in_range,
        "INLIMITS": ("" if (lo, hi) == (None, None) else
                     f",\n * a y outside the input limits [{'-inf' if lo is None else repr(lo)}"
                     f", {'inf' if hi is None else repr(hi)}],"),
        "STEP": step.name, "RESET": reset.name, "LAW": law.name, "NC": str(n_coef),
        "COEF": "" if coef is None else coef.name,
        "COEF_ARGS": ", ".join(f"c[{i}]" for i in range(n_coef)),
        "DT": options.literal(dt if dt is not None else 0.0),
        # wherever the driver and the setter clear skipped (a taken sample, a restart,
        # init), the next step spans one period: a law with coefficients then takes coef[0]
        **{f"HELD_{n}": "" if coef is None else " " * n + "s->held = 0;\n" for n in (4, 8)},
    }
    # the law's pieces first (they hold @-names the second pass fills)
    # the coefficients of the sample period, and of the period the next step spans after
    # rejected samples (computed again when one is rejected: _COEFFICIENTS_SKIP)
    coef_at = "" if coef is None else (_coefficients_at(coef.name, n_coef, 0, "@DT@")
                                       + _coefficients_at(coef.name, n_coef, 1, _LONGER))
    skip = _fill(law.skip, {"LONGER": "" if coef is None else _coefficients_at(
        coef.name, n_coef, 1, _LONGER, "        ")})
    parts = {"INIT_PARAMS": ("" if frozen else "    s->params = @P@_default_params;\n")
             + coef_at,
             "INIT": law.init, "NO_FPU": _NO_FPU[real],
             "BUMPLESS": law.bumpless, "CALL": law.call, "SKIP": skip,
             "SKIP_INNER": textwrap.indent(skip, "    "),
             "CLAMP_U": _clamp(law.limits, "u", "        "),
             # last: the law's pieces above hold its @-names
             **_memory(law, n_cs, tr.constants, prefix.upper())}
    driver = _fill(_fill(_DRIVER, parts), subs)
    if frozen:  # no setter reads whether the law has taken a sample
        driver = re.sub(r"^ *s->fresh = [01];\n", "", driver, flags=re.M)
    else:
        driver += _fill(_fill(_SETTER, {
            "INVALID": invalid.name,
            "CLAMP_OUT4": _clamp(law.limits, "s->last_output", "    "),
            "FIELD_OF": "".join(f"    case {row}: return {prefix.upper()}_FIELD_{name.upper()};\n"
                                for name, row, _ in tunable),
            "SAME": " &&\n        ".join(f"p->{name} == s->params.{name}"
                                           for name, _, _ in tunable),
            "INIT_LAW": textwrap.indent(law.init, "    "), "SET_COEF": coef_at}), subs)
        # the translated law takes the parameter struct first
        names = "|".join(f.name for f in roots if f is not invalid)
        driver = re.sub(rf"\b({names})\((s->cs|w)\b", r"\1(&s->params, \2", driver)

    def row_read(m):  # a parameter row the driver reads (the output limits)
        row = int(m[1])
        if fields is not None and row in fields:
            return f"s->params.{fields[row]}"
        return f"{table}[{tr.param_names.get(row, row)}]"

    driver = re.sub(rf"\b{table}\[(\d+)\]", row_read, driver)
    driver = re.sub(r"\bs->cs\b(?!\.)", "s->cs.row", driver)  # the rows of the union
    banner = _banner(prefix, ctrl, description, f"({law.name} law family, {real})",
                     "baked in" if frozen else
                     f"as exported; {prefix}_set_params changes the tunable ones", _FLOAT_TAIL)
    period = (f"/* sample period (s) the law was built for: call {prefix}_step once per "
              f"period */\n#define {prefix.upper()}_SAMPLE_TIME {options.literal(dt)}"
              if dt is not None else
              "/* no sample period: the law takes its samples as equally spaced */")
    code = tr.source(roots, names=False)  # the names go into the header
    header = _fill(_HEADER, {**subs, "BANNER": banner, "GUARD": f"MFCONTROL_{prefix}_H",
                             "REAL": real, "PERIOD": period,
                             "PARAMS": "" if frozen else _params_header(prefix, tunable, law),
                             "NAMES": (tr.constant_names() + "\n\n"
                                       if tr.constants else ""),
                             "MEMORY": _memory_type(prefix, law, n_cs, tr),
                             "STATE_PARAMS": "" if frozen else _STATE_PARAMS,
                             "BACKUP": "" if law.backup is None else
                             _BACKUP_MEMBER.replace("@NB@", str(law.backup.rows)),
                             "FRESH": "" if frozen else _FRESH_MEMBER,
                             "COEF_MEMBER": "" if coef is None else _COEF_MEMBER,
                             "NC1": str(n_coef + 1),
                             "HELD": "" if coef is None else _HELD_MEMBER,
                             "SET_PARAMS": "" if frozen else _SET_PARAMS_DECL})
    header = _fill(header, subs)
    parts_c = [f"{banner}\n#include <math.h>\n#include \"{prefix}.h\"",
               _fill(_CHECKS[real], {"P": prefix}),
               # the named view of the memory lies on its rows: no padding between them
               f"/* the named rows of {prefix}_memory are its rows: the build stops where "
               "not */\n"
               f"typedef char {prefix}_memory_layout[sizeof({prefix}_memory_rows) == "
               f"{n_cs} * sizeof({prefix}_real) ? 1 : -1];"]
    if re.search(rf"\b{table}\[", code + driver):
        # the rows that fix the law's structure (every row in a frozen build): constants,
        # folded into the code
        rows = ",\n".join(f"    {options.literal(float(v))} /* {i}"
                           f"{': ' + tr.param_names[i] if i in tr.param_names else ''} */"
                           for i, v in enumerate(cp))
        what = "parameters" if frozen else "fixed parameters (its structure)"
        parts_c.append(f"/* the law's {what}, rows of mfcontrol.laws ({law.name}) */\n"
                       f"static const {prefix}_real {table}[{len(cp)}] = {{\n{rows}\n}};")
    if not frozen:
        values = ",\n".join(f"    {options.literal(float(cp[row]))} /* {name} */"
                             for name, row, _ in tunable)
        parts_c.append(f"/* the parameters exported (mfcontrol.laws.{law.module_name} rows, "
                       f"by name) */\nconst {prefix}_params {prefix}_default_params = "
                       f"{{\n{values}\n}};")
    source = "\n\n".join([*parts_c, code, driver])
    return CSource(prefix, real, header, source, law.name, n_cs,
                   tuple(name for name, _, _ in tunable))


def _params_header(prefix: str, tunable, law) -> str:
    width = max(len(name) for name, _, _ in tunable)
    members = "\n".join(f"    {prefix}_real {name + ';':<{width + 1}} /* {_comment(what)} */"
                         for name, _, what in tunable)
    codes = ",\n".join(f"    {prefix.upper()}_FIELD_{name.upper()} = {i + 1}"
                        for i, (name, _, _) in enumerate(tunable))
    return (f"/* The parameters a running controller may change ({prefix}_set_params): the\n"
            f" * tunable rows of mfcontrol.laws.{law.module_name}, by name. Every other row\n"
            " * fixes the law's structure and is a constant of the code. */\n"
            f"typedef struct {{\n{members}\n}} {prefix}_params;\n\n"
            f"/* what {prefix}_set_params returns: 0 taken, -1 a state never initialised, or\n"
            " * the member at fault */\n"
            f"enum {{\n{codes}\n}};\n\n"
            "/* the parameters exported: what init starts from */\n"
            f"extern const {prefix}_params {prefix}_default_params;\n")


#: compile-time checks of the target's arithmetic (a negative array size stops the build)
_NO_CONTRACTION = """/* no multiply-add contracted into one rounding, whatever the flags (the law's
 * arithmetic is mfcontrol's, operation by operation) */
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize ("fp-contract=off")
#endif
/* the guards test for NaN and infinity: -ffast-math (or -ffinite-math-only) lets the
 * compiler assume there are none and remove them, and an infinite setpoint then drives
 * the output to a rail for good */
#if defined(__FAST_MATH__) || (defined(__FINITE_MATH_ONLY__) && __FINITE_MATH_ONLY__)
#error "-ffast-math or -ffinite-math-only remove the NaN and infinity guards: compile without"
#endif
"""
_CHECKS = {
    "double": (_NO_CONTRACTION
               + "/* computing what mfcontrol computes needs IEEE binary64 doubles evaluated\n"
               " * without excess precision (not avr-gcc's 32-bit double, not x87): export\n"
               " * with --float float for such a target */\n"
               "typedef char @P@_double_must_be_64_bit[sizeof(double) == 8 ? 1 : -1];\n"
               "typedef char @P@_double_without_excess_precision"
               "[sizeof(double_t) == sizeof(double) ? 1 : -1];"),
    "float": (_NO_CONTRACTION
              + "/* the float law's rounding bound holds for IEEE binary32 evaluated without\n"
              " * excess precision (not x87 arithmetic: compile with SSE, or export double) */\n"
              "typedef char @P@_float_must_be_32_bit[sizeof(float) == 4 ? 1 : -1];\n"
              "typedef char @P@_float_without_excess_precision"
              "[sizeof(float_t) == sizeof(float) ? 1 : -1];"),
}


def _fixed(ctrl, prefix: str, description: str, key_prefix: str, frozen: bool,
           real: str) -> CSource:
    """The fixed-point export, tunable unless ``frozen``: the PID in q31 or q15
    (:mod:`mfcontrol.cexport.fixed_point`) and the i-P family with the backward difference
    in q31 (:mod:`mfcontrol.cexport.fixed_point_intelligent`)."""
    from .fixed_point import pid_source
    from .fixed_point_intelligent import q31_intelligent_source

    if isinstance(ctrl, PID):
        name = "pid"
    elif isinstance(ctrl, IntelligentController) and real == "q31":
        name = "intelligent"
    elif real == "q31":
        raise ConfigError("real", "q31", f"exports the PID and the i-P, i-PI, i-PD and "
                          f"i-PID (this is the {_law_label(ctrl)} law): export it in float "
                          "or double")
    else:  # why not: the estimate of F divides a code's step by h^n, 2^16 times coarser
        raise ConfigError("real", real, f"exports the PID only (this is the "
                          f"{_law_label(ctrl)} law): q31 exports the i-P family with the "
                          "backward difference, float or double every law")
    banner = _banner(prefix, ctrl, description, f"in fixed point ({real})", "baked in"
                     if frozen else f"as exported; {prefix}_set_params changes the "
                     "coefficients and limits", " * C99 with <stdint.h>, integer "
                     "arithmetic only: no floating point, no dynamic memory,\n * no global "
                     "state. */")
    if name == "pid":
        header, source = pid_source(ctrl, prefix=prefix, banner=banner,
                                    key_prefix=key_prefix, frozen=frozen, real=real)
    else:
        header, source = q31_intelligent_source(ctrl, prefix=prefix, banner=banner,
                                                key_prefix=key_prefix, frozen=frozen)
    return CSource(prefix, real, header, source, name, 0)


def law_of(ctrl, real: str = "double", key_prefix: str = "") -> _Law:
    """The law family of a live controller: its step and reset functions (roots of the
    translation) and the C around them."""
    if isinstance(ctrl, IntelligentController):
        return _intelligent(ctrl, real, key_prefix)
    if isinstance(ctrl, RecursiveIP):
        return _recursive()
    if isinstance(ctrl, PID):
        return _terms_law("pid", pid, (CS, J, REAL))
    if isinstance(ctrl, ADRC):
        law = _terms_law("adrc", adrc, (CP, CS, J, REAL))
        law.regions = {adrc.N_STATE: ("ring", "the delay's ring: the outputs of the last "
                                      "d samples")}
        return law
    raise TypeError(f"cannot export a {type(ctrl).__name__}: export an IP, IPI, IPD, IPID, "
                    "PID, ADRC or RecursiveIP")


@dataclass
class _Law:
    name: str
    module: Any  # the law's module in mfcontrol.laws (its tunable rows, invalid_row)
    step: object
    step_kinds: tuple
    reset: object
    reset_kinds: tuple
    init: str  # C statements of init after the state is zeroed
    bumpless: str  # C statements: restart the law from `start`
    call: str  # C statements: run the law; set `u`, and `out`, what must be finite of it
    state_rows: dict
    limits: tuple[int, int]  # parameter rows of the output limits
    skip: str = ""  # C statements: a sample the law did not take (laws with a period)
    replace: dict = field(default_factory=dict)  # law function -> the one the C calls
    extra_rows: int = 0  # state rows the replacements keep after the law's own
    nan_row: int | None = None  # a row NaN by design once used (as mfcontrol.engine.live)
    # the law's coefficients(CP, j, h) (what a sample computes from the parameters and its
    # period alone), which `step` then takes after its own arguments: computed when the
    # parameters are set, kept in the state, and recomputed only for a longer period
    coefficients: object = None
    # None: the step runs on a copy of the memory in local variables, checked, then
    # written back (the compiler keeps the copy in registers: no backup is stored)
    backup: _Backup | None = None
    # the memory's regions read at computed offsets: first row -> (member name, what)
    regions: dict = field(default_factory=dict)

    @property
    def module_name(self) -> str:
        return self.module.__name__.rsplit(".", 1)[-1]


@dataclass
class _Backup:
    """A law whose memory is too large to copy every step (the algebraic estimator's ring):
    the rows its step may write are backed up before it and restored after an overflow."""

    rows: int  # rows of the state's backup
    save: str  # C statements: copy what the step may write into s->backup
    restore: str  # and back
    # C statements: CHECK(x); for every row x the step wrote (cs: the memory), as
    # mfcontrol.engine.live checks the whole memory; _finite_check makes them C
    finite: str


#: a law with a period (intelligent, PID): called with the time since the last sample it
#: took, and a sample it did not take adds its period to that
_SAMPLED_CALL = "    u = @STEP@(@CS@, y, setpoint, @DT@ + s->skipped);\n    out = u;\n"
_SAMPLED_SKIP = "        s->skipped += @DT@;\n"
#: a law with a period and coefficients: the state's set for the period the step spans,
#: coef[held] (the sample period's, or the longer one's computed when a sample was rejected)
_COEFFICIENTS_CALL = """\
    {
        /* the sample period's coefficients, or the longer period's after a rejected sample
         * (computed then: no call on this path, which would make the compiler spill the
         * law's values around it), the period last */
        const @R@ *c = s->coef[s->held];
        u = @STEP@(@CS@, y, setpoint, c[@NC@], @COEF_ARGS@);
    }
    out = u;
"""
#: and a sample it did not take adds its period to the next step's, whose coefficients it
#: computes
_COEFFICIENTS_SKIP = _SAMPLED_SKIP + "@LONGER@        s->held = 1;\n"
#: the period the next step spans after rejected samples
_LONGER = "@DT@ + s->skipped"


def _coefficients_at(name: str, n: int, which: int, h: str, indent: str = "    ") -> str:
    """C statements: set ``which`` of the state's coefficient sets (0: the sample
    period's, 1: the longer one's) for the period ``h``, the period last."""
    out = ", ".join(f"&s->coef[{which}][{i}]" for i in range(n))
    return f"{indent}{name}(s->cs, {h}, {out});\n{indent}s->coef[{which}][{n}] = {h};\n"


def _clamp(limits: tuple[int, int], var: str = "start", indent: str = "    ") -> str:
    lo, hi = limits
    return (f"{indent}if ({var} < @P@_fixed[{lo}]) {var} = @P@_fixed[{lo}];\n"
            f"{indent}if ({var} > @P@_fixed[{hi}]) {var} = @P@_fixed[{hi}];\n")


def _intelligent(ctrl, real: str, key_prefix: str) -> _Law:
    cp = ctrl._CP[:, 0]
    if cp[gain_law.MODE] == gain_law.EXTERNAL:
        raise ConfigError("gain", "external", "the exported step has no alpha argument: "
                          "export a constant or variational gain")
    if cp[intelligent.DELAY] > 0:
        raise ConfigError(f"{key_prefix}delay", int(cp[intelligent.DELAY]),
                          "the exported step compensates no delay yet: export with delay 0")
    limits = (intelligent.OUT_MIN, intelligent.OUT_MAX)
    law = _Law(
        "intelligent", intelligent, intelligent.step, (CP, CS, J, REAL, REAL, REAL),
        intelligent.reset, (CP, CS, J),
        init=f"    @RESET@(s->cs);\n    s->last_output = @P@_fixed[{intelligent.U_INIT}];\n",
        bumpless=(f"    @RESET@(s->cs);\n{_clamp(limits)}"
                  f"    s->cs[{intelligent.U1}] = start;\n    s->cs[{intelligent.U2}] = start;\n"
                  "    s->last_output = start;\n"),
        call=_SAMPLED_CALL, state_rows={}, limits=limits, skip=_SAMPLED_SKIP)
    law.regions = {intelligent.EST_BASE: ("estimator", "the algebraic estimator's memory "
                                          "(mfcontrol.laws.estimators: its count, moments "
                                          "and ring)")}
    if cp[intelligent.EST] == intelligent.ALGEBRAIC:
        M = int(cp[intelligent.M_WIN])
        if M > MAX_WINDOW[real]:
            raise ConfigError(f"{key_prefix}window", M, f"at most {MAX_WINDOW[real]:,} samples "
                              f"in a {real} export (the estimator's sample count must stay "
                              "exact)")
        # the resync spread over the samples: no step is O(M) (the same bits)
        law.replace = {estimators.push: estimators.push_spread}
        law.extra_rows = estimators.SPREAD_ROWS
        # a step writes every row before the ring, one y and one u slot of the ring and
        # the next resync's moments after it: back up those (O(1)), not the whole window
        head = intelligent.EST_BASE + estimators.RING
        count = intelligent.EST_BASE + estimators.COUNT
        spread = intelligent.EST_BASE + estimators.n_state(M)
        n_spread = estimators.SPREAD_ROWS
        law.regions[spread] = ("resync", "the next resync's moments, summed a few samples "
                               "a step (estimators.push_spread)")
        slot = f"((long)s->cs[{count}] % {M + 1})"
        # the slots the step wrote, found from the count before it (in the backup); the
        # rest of the ring holds samples already taken, finite. The next resync's moments
        # are not checked: the live controller's memory has no such rows, and what they
        # hold reaches the checked moments at the resync, as the live resync's sums do
        old = f"((long)s->backup[{count}] % {M + 1})"
        law.backup = _Backup(
            rows=head + 2 + n_spread,
            save=(f"    for (i = 0; i < {head}; i++) s->backup[i] = s->cs[i];\n"
                  f"    s->backup[{head}] = s->cs[{head} + {slot}];\n"
                  f"    s->backup[{head + 1}] = s->cs[{head + M + 1} + {slot}];\n"
                  f"    for (i = 0; i < {n_spread}; i++) "
                  f"s->backup[{head + 2} + i] = s->cs[{spread} + i];\n"),
            # the rows before the ring first: the slots are found from the count they hold
            restore=(f"    for (i = 0; i < {head}; i++) s->cs[i] = s->backup[i];\n"
                     f"    s->cs[{head} + {slot}] = s->backup[{head}];\n"
                     f"    s->cs[{head + M + 1} + {slot}] = s->backup[{head + 1}];\n"
                     f"    for (i = 0; i < {n_spread}; i++) "
                     f"s->cs[{spread} + i] = s->backup[{head + 2} + i];\n"),
            finite=(f"    for (i = 0; i < {head}; i++) CHECK(cs[i]);\n"
                    f"    CHECK(cs[{head} + {old}]);\n"
                    f"    CHECK(cs[{head + M + 1} + {old}]);\n"))
    return law


def _recursive() -> _Law:
    # the live controller restarts the law from the manual output by rewriting its u0
    # parameter: in C that one row lives in the state, after the law's own rows
    u0 = recursive_ip.N_STATE
    return _Law(
        "recursive", recursive_ip, recursive_ip.step, (CP, CS, J, REAL, REAL),
        recursive_ip.reset, (CP, CS, J),
        init=(f"    s->cs[{u0}] = @P@_fixed[{recursive_ip.U0}];\n    @RESET@(s->cs);\n"
              "    s->last_output = 0;\n"
              f"{_clamp((recursive_ip.OUT_MIN, recursive_ip.OUT_MAX), 's->last_output')}"),
        bumpless=(f"    @RESET@(s->cs);\n"
                  f"    s->cs[{u0}] = start / @P@_fixed[{recursive_ip.OUT_GAIN}];\n"
                  "    s->last_output = start;\n"),
        call=("    {\n        @R@ raw = 0, gain = 0, gamma = 0;\n"
              "        @STEP@(@CS@, y, setpoint, &raw, &u, &gain, &gamma);\n"
              "        out = raw * 0 + u;\n    }\n"),
        state_rows={recursive_ip.U0: u0}, limits=(recursive_ip.OUT_MIN, recursive_ip.OUT_MAX),
        regions={u0: ("u0", "the law's u0 parameter, which a bumpless start rewrites")})


def _terms_law(name: str, law, reset_kinds: tuple) -> _Law:
    """A law whose reset takes the first output (NaN: none) and whose START row holds it
    until used (:mod:`mfcontrol.laws.pid`, :mod:`mfcontrol.laws.adrc`): the C around it
    is the same, restarted bumplessly through that reset."""
    limits = (law.OUT_MIN, law.OUT_MAX)
    return _Law(
        name, law, law.step_at, (CP, CS, J, REAL, REAL, REAL), law.reset, reset_kinds,
        init=("    @RESET@(s->cs, (@R@)NAN);\n    s->last_output = 0;\n"
              f"{_clamp(limits, 's->last_output')}"),
        nan_row=law.START,  # the start row is NaN once used (or when there is none)
        bumpless=(f"{_clamp(limits)}    @RESET@(s->cs, start);\n"
                  "    s->last_output = start;\n"),
        call=_COEFFICIENTS_CALL, state_rows={}, limits=limits, skip=_COEFFICIENTS_SKIP,
        coefficients=law.coefficients)


@functools.cache
def _row_comments(module) -> dict[str, str]:
    """The comments on a law module's constants (``NAME = ...  # what it is``), made
    inert as C comment text (read once per module)."""
    comments = {}
    for line in inspect.getsource(module).splitlines():
        m = re.match(r"^([A-Z][A-Z0-9_]*) = [^#]*#\s*(.*)$", line)
        if m:
            text = m[2]
            noqa = re.match(r"noqa: \w+ \((.*)\)$", text)  # `# noqa: E741 (what it is)`
            text = noqa[1] if noqa else text.split("  # noqa")[0]
            comments[m[1]] = text.replace("*/", "* /").replace("/*", "/ *").strip()
    return comments


#: names a member may not take in a header C++ includes too
_CPP_KEYWORDS = {"and", "bool", "catch", "class", "delete", "false", "friend", "new",
                 "not", "operator", "or", "private", "protected", "public", "template",
                 "this", "throw", "true", "try", "typename", "using", "virtual", "xor"}


def _memory_type(prefix: str, law: _Law, n_cs: int, tr: Translator) -> str:
    """The C type of a state's memory: a union of its rows (``row[N]``, as the translated
    law indexes them) and the same rows by name (``named``): each row the law reads by a
    constant is a member named as the constant, the rows it reads at computed offsets
    (a window, a ring) arrays named after their region."""
    names: dict[int, tuple[str, str, str]] = {}  # row -> (member, comment, C name)
    taken = {label for label, _ in law.regions.values()} | _C_KEYWORDS | _CPP_KEYWORDS
    for row, code in sorted(tr.state_names.items()):
        module, attr = tr.origins[code]
        member = attr.lower()
        if member in taken:  # another module's row of that name, or a keyword: qualified
            member = f"{module.__name__.rsplit('.', 1)[-1]}_{attr}".lower()
        while member in taken:
            member += "_"
        taken.add(member)
        names[row] = (member, _row_comments(module).get(attr, ""), code)
    lines, row = [], 0
    while row < n_cs:
        if row in names:
            member, comment, code = names[row]
            lines.append((f"{prefix}_real {member};", f"{comment} ({code})" if comment
                          else code))
            row += 1
            continue
        end = row + 1  # a run of rows read at computed offsets, up to a region's start
        while end < n_cs and end not in names and end not in law.regions:
            end += 1
        label, what = law.regions.get(row, (f"rows_{row}", "rows read at computed offsets"))
        lines.append((f"{prefix}_real {label};", f"{what} (row {row})") if end == row + 1
                     else (f"{prefix}_real {label}[{end - row}];",
                           f"{what}: rows {row} to {end - 1}"))
        row = end
    width = max(len(c) for c, _ in lines)
    body = "".join(f"    {c:<{width}} /* {w} */\n" for c, w in lines)
    return ("/* the law's memory by name: its rows in order, each row the law reads by a\n"
            " * constant named as that constant, in lower case */\n"
            f"typedef struct {{\n{body}}} {prefix}_memory_rows;\n\n"
            "/* the law's memory: row[] is what the law reads and writes; named, the same rows\n"
            " * by name (a debugger's watch, a log: the two lie on the same storage) */\n"
            f"typedef union {{\n    {prefix}_real row[{n_cs}];\n"
            f"    {prefix}_memory_rows named;\n}} {prefix}_memory;\n\n")


def _memory(law: _Law, n_cs: int, constants: dict[str, int], pu: str) -> dict[str, str]:
    """The step's protection of the law's memory (pieces of :data:`_DRIVER`): a copy in
    local variables that the law runs on, checked and then written back, or, for a law
    with a :class:`_Backup`, the rows it may write backed up and restored on overflow.
    ``constants``: the header's names of the law's constants; ``pu``: their prefix."""
    if law.backup is None:
        guarded = getattr(law.module, "GUARDED", None)
        if guarded is not None:
            # the rows whose finiteness, with the output's, is the whole memory's (the law
            # says why and tests it): the others need no test of their own
            def row(name: str) -> str:  # by the header's name when the law's code has it
                c_name = f"{pu}_{law.module_name.upper()}_{name}"
                return c_name if c_name in constants else str(getattr(law.module, name))
            finite = (f"    /* {law.module.__name__}.GUARDED: with the output's, their "
                      "finiteness is the memory's */\n"
                      + "".join(f"    CHECK(cs[{row(name)}]);\n" for name in guarded))
        else:
            rows = [i for i in range(n_cs) if i != law.nan_row]
            finite = "".join(f"    CHECK(cs[{i}]);\n" for i in rows)
            if law.nan_row is not None:
                r = law.nan_row
                finite += (f"    if (cs[{r}] == cs[{r}]) {{ /* NaN: used */\n"
                           f"        CHECK(cs[{r}]);\n    }}\n")

        def copies(dst: str, src: str) -> str:  # straight-line: every index a constant
            return "".join(f"    {dst}[{i}] = {src}[{i}];\n" for i in range(n_cs))
        parts = {"BACKUP_FUNCS": "", "BACKUP_INIT": "", "CS": "w", "UNDO": "",
                 "LOCALS": "    @R@ w[@NS@];\n",
                 "BEFORE": ("    /* the law runs on a copy, written back once checked */\n"
                            + copies("w", "s->cs")),
                 "COMMIT": copies("s->cs", "w"), "UNUSED_S": "    (void)s;\n"}
    else:
        finite = law.backup.finite
        parts = {"BACKUP_FUNCS": _fill(_BACKUP_FUNCS, {"SAVE": law.backup.save,
                                                        "RESTORE": law.backup.restore}),
                 "BACKUP_INIT": f"    for (i = 0; i < {law.backup.rows}; i++) "
                                "s->backup[i] = 0;\n",
                 "CS": "s->cs", "UNDO": "        @P@_restore(s);\n", "LOCALS": "",
                 "BEFORE": "    @P@_save(s);\n", "COMMIT": "", "UNUSED_S": ""}
    loop = "    long i;\n" if "i++" in finite else ""
    return {**parts, "FINITE": loop + _finite_check(finite, "acc += {x} - {x};"),
            "FINITE_SOFT": loop + _finite_check(finite, "if (!isfinite({x})) return 0;")}


def _finite_check(text: str, form: str) -> str:
    """The C statements ``text`` with each ``CHECK(x);`` in ``form``."""
    return re.sub(r"CHECK\((.*?)\);", lambda m: form.format(x=m[1]), text)


#: the preprocessor's test for a target without a floating-point unit for the type (an
#: ARM or RISC-V core whose FPU, if any, lacks that precision)
_NO_FPU = {
    "double": ("(defined(__arm__) && (!defined(__ARM_FP) || !(__ARM_FP & 8))) || \\\n"
               "    (defined(__riscv) && (!defined(__riscv_flen) || __riscv_flen < 64))"),
    "float": ("(defined(__arm__) && (!defined(__ARM_FP) || !(__ARM_FP & 4))) || \\\n"
              "    (defined(__riscv) && !defined(__riscv_flen))"),
}


def _fill(text: str, subs: dict) -> str:
    for key, value in subs.items():
        text = text.replace(f"@{key}@", value)
    return text


def _comment(text: str) -> str:
    """``text`` as inert C comment text, its lines joined by newlines: nothing in it ends
    the comment (``*/``) or splices the next line into it (a backslash, or the trigraph
    ``??/``, at a line's end: the splice happens before comments are seen), and a control
    character shows as ``<U+XXXX>``."""
    lines = []
    for line in str(text).split("\n"):
        line = "".join(c if c.isprintable() else f"<U+{ord(c):04X}>" for c in line).rstrip()
        line = re.sub(r"\?(?=\?)", "? ", line)  # no trigraph (??/ is a backslash)
        while "*/" in line or "/*" in line:
            line = line.replace("*/", "* /").replace("/*", "/ *")
        if line.endswith("\\"):
            line = line[:-1] + "<U+005C>"
        lines.append(line)
    return "\n".join(lines)


def _law_label(ctrl) -> str:
    """The law as the command line and the case files name it (``controller.law``): an
    ``IPI`` is an ``i-PI``, a ``PID`` a ``pid``, a ``RecursiveIP`` the ``ip`` or the
    ``variational`` law it was built as."""
    from ..api.model.controllers import _LAW_NAMES

    name = type(ctrl).__name__
    if name in _LAW_NAMES:
        return _LAW_NAMES[name]
    if name in ("PID", "ADRC"):
        return name.lower()
    if name == "RecursiveIP":
        return ("variational" if ctrl._CP[gain_law.MODE, 0] == gain_law.VARIATIONAL
                else "ip")
    return name


def _banner(prefix: str, ctrl, description: str, made: str, how: str, tail: str) -> str:
    """The files' leading comment: the controller, how it was ``made``, the case it came
    from, its parameters (``how`` they are held) and the ``tail`` lines."""
    params = "\n".join(f" *   {k} = {_comment(repr(v))}" for k, v in ctrl._params.items())
    what = "".join(f" * {line}".rstrip() + "\n"
                   for line in _comment(description).split("\n")) if description else ""
    return (f"/* {prefix}: {_law_label(ctrl)} controller (mfcontrol.{type(ctrl).__name__}) "
            f"exported by mfcontrol {__version__} {made}.\n{what}"
            f" * Parameters ({how}):\n{params}\n{tail}")


#: the floating-point exports' last banner lines
_FLOAT_TAIL = (" * C99, no dynamic memory, no global state, only <math.h>. Compile without\n"
               " * floating-point contraction (this file turns it off for gcc and clang; other\n"
               " * compilers: -ffp-contract=off or theirs) and without -ffast-math to compute,\n"
               " * in double, exactly what mfcontrol computes.\n */")


_HEADER = """@BANNER@
#ifndef @GUARD@
#define @GUARD@

#ifdef __cplusplus
extern "C" {
#endif

typedef @REAL@ @R@;

@PERIOD@
#define @PU@_N_STATE @NS@
/* taken samples in a row whose step overflows after which the law restarts from its last
 * output (one is the sample's fault and is rejected; a second in a row, the memory's) */
#define @PU@_RESTART_AFTER @RESTART@
/* a state's mode: automatic ("mfc1"), manual ("mfc0") */
#define @PU@_AUTO 0x6D666331UL
#define @PU@_MANUAL 0x6D666330UL

@NAMES@@PARAMS@@MEMORY@typedef struct {
@STATE_PARAMS@    /* the law's memory: cs.row[PREFIX_MODULE_NAME] as the law indexes it, or
     * cs.named.<row> (@P@_memory) */
    @P@_memory cs;
@BACKUP@@COEF_MEMBER@    /* returned in manual mode and after a rejected sample */
    @R@ last_output;
    /* time (s) of the samples the law did not take since its last one: the next step's
     * derivatives and integral span it */
    @R@ skipped;
@HELD@    /* steps in a row that overflowed */
    unsigned overflows;
@FRESH@    /* rejected values: a non-finite measurement or setpoint, a measurement outside the
     * input limits, a step that overflowed, a non-finite manual value */
    unsigned long nan_count;
    /* restarts of the law because its memory overflowed (@PU@_RESTART_AFTER steps in a row
     * overflowed) */
    unsigned long restarts;
    /* @PU@_AUTO or @PU@_MANUAL (set by @P@_init, @P@_set_manual, @P@_set_auto); any other
     * value is a state never passed to @P@_init (a zeroed static one included), which every
     * function refuses rather than run on whatever its memory holds */
    unsigned long mode;
} @P@_state;

/* Start (or restart) the controller: automatic mode, no history. Call it once before any
 * other function on the state. */
void @P@_init(@P@_state *s);
/* One sample: the measurement y and the setpoint in, the limited control out.
 * A non-finite y or setpoint@INLIMITS@
 * or a step that overflows (its output or memory not finite) returns the last output,
 * leaves the memory as it was and counts in nan_count.
 * On a state never passed to @P@_init: returns NaN and changes nothing. */
@R@ @P@_step(@P@_state *s, @R@ y, @R@ setpoint);
/* Manual mode: every step returns u, clamped to the output limits, until @P@_set_auto
 * (a non-finite u is not taken: the last output stays, and nan_count counts it). */
void @P@_set_manual(@P@_state *s, @R@ u);
/* Back to automatic, restarting the law from the last output (bumpless). */
void @P@_set_auto(@P@_state *s);
@SET_PARAMS@
#ifdef __cplusplus
}
#endif

#endif
"""

_DRIVER = """/* the live controller around the law (as mfcontrol.api.model.controllers) */

/* a state passed to @P@_init: its mode is one of the two */
#define @PU@_INITIALISED(s) ((s)->mode == @PU@_AUTO || (s)->mode == @PU@_MANUAL)
@BACKUP_FUNCS@
/* 1 when the step's output (out) and the memory it wrote (cs) hold only finite values.
 * With a floating-point unit for the real type, x - x is 0 for a finite x and NaN for an
 * infinite or NaN one, so one comparison tests their sum, without a branch per row
 * (-ffast-math, which would fold x - x to 0, is refused above); without one, the
 * arithmetic is a library call and isfinite an integer test, so each row is tested */
#if @NO_FPU@
static int @P@_finite(const @P@_state *s, const @R@ *cs, @R@ out)
{
@UNUSED_S@    if (!isfinite(out)) return 0;
@FINITE_SOFT@    return 1;
}
#else
static int @P@_finite(const @P@_state *s, const @R@ *cs, @R@ out)
{
    @R@ acc = out - out;
@UNUSED_S@@FINITE@    return acc == 0;
}
#endif

static void @P@_bumpless(@P@_state *s, @R@ start);

void @P@_init(@P@_state *s)
{
    long i;
    for (i = 0; i < @NS@; i++) s->cs[i] = 0;
    s->skipped = 0;
@HELD_4@@BACKUP_INIT@@INIT_PARAMS@@INIT@    s->nan_count = 0;
    s->restarts = 0;
    s->overflows = 0;
    s->fresh = 1;
    s->mode = @PU@_AUTO;
}

@R@ @P@_step(@P@_state *s, @R@ y, @R@ setpoint)
{
    @R@ u = 0, out = 0;
@LOCALS@    if (s->mode != @PU@_AUTO) /* (one test on the way of every sample) */
        return s->mode == @PU@_MANUAL ? s->last_output : (@R@)NAN;
    if (!isfinite(y) || !isfinite(setpoint)@RANGE@) {
        s->nan_count++;
@SKIP@        return s->last_output;
    }
@BEFORE@@CALL@    if (!@P@_finite(s, @CS@, out)) {
@UNDO@        s->nan_count++;
        if (++s->overflows < @PU@_RESTART_AFTER) {
@SKIP_INNER@            return s->last_output;
        }
        @P@_bumpless(s, s->last_output);
        s->overflows = 0;
        s->skipped = 0;
@HELD_8@        s->restarts++;
        return s->last_output;
    }
@COMMIT@    s->last_output = u;
    s->skipped = 0;
@HELD_4@    s->overflows = 0;
    s->fresh = 0;
    return u;
}

void @P@_set_manual(@P@_state *s, @R@ u)
{
    if (!@PU@_INITIALISED(s)) return;
    s->mode = @PU@_MANUAL;
    if (isfinite(u)) {
@CLAMP_U@        s->last_output = u;
    } else {
        s->nan_count++;
    }
}

static void @P@_bumpless(@P@_state *s, @R@ start)
{
    s->fresh = 0;
@BUMPLESS@}

void @P@_set_auto(@P@_state *s)
{
    if (!@PU@_INITIALISED(s)) return;
    if (s->mode == @PU@_MANUAL) {
        @P@_bumpless(s, s->last_output);
        s->skipped = 0;
@HELD_8@        s->overflows = 0;
    }
    s->mode = @PU@_AUTO;
}
"""

_BACKUP_MEMBER = """\
    /* the memory the current step may overwrite, as it was before the step */
    @R@ backup[@NB@];
"""

_COEF_MEMBER = """\
    /* what the law computes from its parameters and the period alone, then the period:
     * [0] the sample period's (computed when the parameters are set), [1] the longer one's
     * the next step spans after rejected samples (computed when one is rejected) */
    @R@ coef[2][@NC1@];
"""

_HELD_MEMBER = """\
    /* 1 after a rejected sample (the next step takes coef[1]); 0 after a taken sample, a
     * restart and init */
    unsigned held;
"""

_FRESH_MEMBER = """\
    /* 1 until the law takes a sample or restarts (@P@_set_params then starts afresh) */
    int fresh;
"""

_BACKUP_FUNCS = """
static void @P@_save(@P@_state *s)
{
    long i;
@SAVE@}

static void @P@_restore(@P@_state *s)
{
    long i;
@RESTORE@}
"""

_STATE_PARAMS = """\
    /* the parameters the law runs with (@P@_set_params changes them: do not
     * write them here, where nothing checks them) */
    @P@_params params;
"""

_SET_PARAMS_DECL = """\
/* Change the parameters while running. Every member is checked: a value the law is
 * not defined for (NaN, a limit pair out of order, N <= 0...) is refused, nothing
 * changes, and the member at fault is returned (@PU@_FIELD_...). Taken: in automatic
 * mode the law restarts from the last output clamped to the new limits (bumpless, as
 * @P@_set_auto does; before any sample it starts as @P@_init would with them; an
 * unchanged set changes nothing), in manual mode the held output is clamped to the new
 * limits. Returns 0 when taken,
 * -1 for a state never initialised (or no parameters). A restart: the sample after it
 * integrates nothing, so it is not a per-sample gain schedule. Call it where @P@_step
 * is called (or with that interrupt masked): the copy is not atomic. */
int @P@_set_params(@P@_state *s, const @P@_params *p);
"""

_SETTER = """
/* the member of @P@_params that holds a parameter row */
static int @P@_field_of(long row)
{
    switch (row) {
@FIELD_OF@    default: return -1; /* (never: the check names tunable rows only) */
    }
}

int @P@_set_params(@P@_state *s, const @P@_params *p)
{
    long row = 0;
    if (!@PU@_INITIALISED(s) || !p) return -1;
    row = @INVALID@(p, s->cs);
    if (row >= 0) return @P@_field_of(row);
    if (@SAME@) return 0; /* nothing changes */
    s->params = *p;
@SET_COEF@    /* the output held (manual, or after a rejected sample) within the new limits */
@CLAMP_OUT4@    if (s->mode == @PU@_MANUAL) return 0;
    if (s->fresh) { /* before any sample: as init with them */
@INIT_LAW@    } else { /* from the last output */
        @P@_bumpless(s, s->last_output);
        s->skipped = 0;
@HELD_8@        s->overflows = 0;
    }
    return 0;
}
"""
