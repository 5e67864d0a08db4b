"""The q31 i-P family (mfcontrol.cexport.fixed_point_intelligent) against the double law.

As tests/cexport/test_fixed_point.py does for the PID: the export is compiled under the
tests' warnings (and -fsanitize=undefined), driven with codes of a case's closed loop,
and compared at every step with the live double controller driven with the same values:
the difference stays within a first-order bound derived along the run from the export's
arithmetic. Hostile codes saturate and never leave the output limits; the Cortex-M0
computes the same codes as x86.
"""

from __future__ import annotations

import math
import subprocess

import numpy as np
import pytest

import mfcontrol
from mfcontrol.cexport import c_source
from mfcontrol.cexport.fixed_point import GUARD_BITS, code
from mfcontrol.cexport.fixed_point_intelligent import q31_intelligent
from mfcontrol.errors import ConfigError
from mfcontrol.laws import intelligent

from . import harness as H
from .test_fixed_point import build, m0_codes, run
from .test_on_target import _require_tools
from .test_source import closed_loop

CASE = "motor-noise-ipi"  # an i-PI of order 1 with the backward difference and the clamp
INPUT_LIMITS = (-128.0, 128.0)  # the measurement's scale 256: codes dequantize exactly
VARIANTS = {
    "ipi-clamp": {},
    "ipi-clamp-narrow": {"controller.duty_min": -2.0, "controller.duty_max": 2.0},
    "ip": {"controller.law": "i-P", "controller.duty_min": -5.0, "controller.duty_max": 5.0},
    "ipid-order2-held-back-calculation": {
        "controller.law": "i-PID", "controller.order": 2, "controller.kd": 0.5,
        "controller.ki": 50.0, "controller.alpha": 2000.0,
        "controller.anti_windup": "back-calculation", "controller.k_aw": 20.0},
    "ipd-order2-trapezoid": {"controller.law": "i-PD", "controller.order": 2,
                             "controller.kd": 0.5, "controller.alpha": 2000.0,
                             "controller.kernel": "trapezoid"},
}


def controller(over):
    ctrl = mfcontrol.make_controller(CASE, over)
    ctrl._take_input_limits(INPUT_LIMITS)
    return ctrl


#: where the run has measurements outside the input limits (rejected): (before which of
#: the case's samples, how many in a row)
REJECTED = ((150, 1), (300, 2), (500, 1), (1000, 3))


def codes_of_the_run(ctrl) -> np.ndarray:
    """The case's closed loop as codes, with measurements outside the input limits among
    them (:data:`REJECTED`), a manual period and the return to automatic."""
    sc = q31_intelligent(ctrl).scales
    y, r = closed_loop(CASE)
    Y = np.array([code(v, sc.y_scale) for v in y])
    R = np.array([code(v, sc.y_scale) for v in r])
    n = len(Y)
    u_manual = code(0.25 * sc.u_hi, sc.u_scale)
    rows = np.column_stack([np.zeros(n), Y, R])
    outside = dict(REJECTED)
    steps = []
    for i, row in enumerate(rows):
        steps += [[0, sc.y_limits[1] + 1 + j, row[2]] for j in range(outside.get(i, 0))]
        steps.append(row)
    steps = np.array(steps)
    half = int(np.searchsorted(np.cumsum(steps[:, 1] <= sc.y_limits[1]), n // 2))
    return np.vstack([steps[:half], [[1, u_manual, 0]], steps[half:half + 5], [[2, 0, 0]],
                      steps[half:]]).astype(np.int64)


def bound_along(ctrl, ops) -> tuple[np.ndarray, np.ndarray]:
    """The double law's outputs for ``ops`` and a first-order bound on |u_q31 - u| at each
    of its steps. Carried from step to step: the errors of the last two applied outputs
    (u_h is made of them) and of the integral term T. Added at each step: each
    coefficient's representation error times its operand (the operands, codes of the
    error, are exact), each product's rounding (half a unit of the guarded output), the
    held kernel's mean's rounding, the limits' codes, the double law's own rounding, and
    the returned code's rounding. The limits are 1-Lipschitz, and where both outputs are
    surely past a limit they are that limit's code exactly. Where the clamp's decision is
    within the bound of its threshold it may go either way in fixed point: T's error
    then grows by the sample's integration. Back-calculation T - c (sat(v) - v), c = K_aw h
    <= 1, does not amplify T's error (slope 1 or 1 - c in T). After d - 1 rejected samples
    the step spans d periods: its difference terms divided by d^n and d (their rounding
    too, and the division's own), T's increment and the back-calculation's c times d."""
    q = q31_intelligent(ctrl)
    sc = q.scales
    py = type(ctrl)(**ctrl._params)
    qy, qu = sc.y_scale / 2**31, sc.u_scale / 2**31
    qg = qu / 2**GUARD_BITS  # a unit of the guarded output
    lo, hi = sc.u_lo, sc.u_hi
    lo_q, hi_q = sc.u_limits[0] * qu, sc.u_limits[1] * qu
    dlim = max(abs(lo_q - lo), abs(hi_q - hi))

    def term_error(c, operand: float) -> float:  # operand in codes
        return (abs(c.exact - c.value) * abs(operand) + 0.5 / 2**GUARD_BITS) * qu
    eps = 2.0**-50  # the double law's own rounding, relative
    gamma = float(ctrl._CP[intelligent.variational_gain.INV_ALPHA, 0])
    alpha = 1.0 / gamma
    n = q.order
    clamp = q.anti_windup == intelligent.AW_CLAMP
    back = q.anti_windup == intelligent.AW_BACK
    c_aw = q.caw.value
    out, bounds = [], []
    u_init = q.u_init * qu
    err_u1 = err_u2 = abs(u_init - float(ctrl._CP[intelligent.U_INIT, 0]))
    err_t = 0.0
    k = 0
    e1 = e2 = 0
    u1_d = u2_d = float(ctrl._CP[intelligent.U_INIT, 0])
    err_last = err_u1
    y_lo, y_hi = sc.y_limits
    d = 1  # the period the next step taken spans, in periods
    for op, a, code_r in ops:
        if op == 1:  # manual: the code, clamped to the limits' codes
            py.set_auto_mode(False, last_output=a * qu)
            err_last = dlim
            continue
        if op == 2:  # from manual, the law restarts from the last output, held for n samples
            assert not py.auto_mode  # (the runs switch to automatic from manual only)
            py.set_auto_mode(True)
            err_u1 = err_u2 = err_last
            err_t = 0.0
            k, e1, e2, d = 0, 0, 0, 1
            u1_d = u2_d = py.last_output
            continue
        if not py.auto_mode:
            out.append(py(a * qy, setpoint=code_r * qy))
            bounds.append(err_last + eps * abs(out[-1]))
            continue
        if not y_lo <= a <= y_hi:  # rejected: the last output, its period spanned next
            out.append(py(a * qy, setpoint=code_r * qy))
            bounds.append(err_last + eps * abs(out[-1]))
            d += 1
            continue
        e = int(a) - int(code_r)
        u = py(a * qy, setpoint=code_r * qy)
        if k < n:  # held
            k += 1
            err_u = err_u1
        else:
            comp = py.components
            v = comp["unlimited"]
            held_mean = q.held_mean
            uh = 0.5 * (u1_d + u2_d) if held_mean else u1_d
            err_uh = (0.5 * (err_u1 + err_u2) + 0.5 * qg) if held_mean else err_u1
            dn = (e - 2 * e1 + e2) if n == 2 else (e - e1)
            div = 0.5 * qg if d > 1 else 0.0  # a division's rounding
            err_a = (err_uh + term_error(q.cn, dn) / d**n + div + term_error(q.cp, e)
                     + (term_error(q.cd, e - e1) / d + div if q.cd.mantissa else 0.0))
            err_a += eps * (gamma * (abs(comp["F_hat"]) + 2 * alpha * abs(uh)
                                     + abs(comp["feedforward"]) + abs(comp["P"])
                                     + abs(comp["I"]) + abs(comp["D"])) + abs(v))
            inc = q.ci.value * e * qu * d  # T's increment this sample
            err_t += term_error(q.ci, e) * d
            err_v = err_a + err_t
            near = err_v + dlim + abs(inc)  # (v is after the double's own undo)
            if clamp and (abs(v - hi) <= near or abs(v - lo) <= near):
                err_t += abs(inc) + term_error(q.ci, e) * d  # the undo may go either way
                err_v = err_a + err_t
            if v - err_v > hi + dlim or v + err_v < lo - dlim:
                err_u = dlim  # both at the limit
            else:
                err_u = err_v + dlim
            if back:
                c = c_aw * d  # slope 1 - c in T: its magnitude at most max(1, c - 1)
                err_t = (err_t * max(1.0, c - 1.0) + c * (err_a + dlim)
                         + (abs(q.caw.exact - c_aw) * abs(u - v) + 0.5 * qg) * d)
        d = 1
        out.append(u)
        bounds.append(err_u + 0.5 * qu + eps * abs(u))
        err_last = err_u + 0.5 * qu
        err_u2, err_u1 = err_u1, err_u
        u2_d, u1_d = u1_d, u
        e2, e1 = e1, e
    return np.array(out), np.array(bounds)


@pytest.mark.parametrize("name", VARIANTS)
def test_the_q31_law_stays_within_its_derived_bound_of_the_double_law(name, tmp_path):
    ctrl = controller(VARIANTS[name])
    src = c_source(ctrl, real="q31")
    ops = codes_of_the_run(ctrl)
    out, nan_count = run(build(src, tmp_path), ops)
    sc = q31_intelligent(ctrl).scales
    u_q = out * (sc.u_scale / 2**31)
    u, bound = bound_along(ctrl, ops)
    err = np.abs(u_q - u)
    worst = int(np.argmax(err / bound))
    assert np.all(err <= bound), (f"step {worst}: |{u_q[worst]!r} - {u[worst]!r}| > "
                                  f"{bound[worst]:.3g}")
    assert nan_count == sum(count for _, count in REJECTED)
    # the bound means something: within 1e-4 of the output's range over the whole run
    assert bound.max() < 1e-4 * (sc.u_hi - sc.u_lo)
    assert err.max() > 0.0  # and the comparison sees the fixed point's rounding


#: coefficients near the ends of their range
EXTREME = {"controller.law": "i-PID", "controller.order": 2, "controller.kd": 50.0,
           "controller.ki": 1e4, "controller.kp": 1e4, "controller.alpha": 0.02,
           "controller.anti_windup": "back-calculation", "controller.k_aw": 999.0,
           "controller.duty_min": -2.0, "controller.duty_max": 2.0}


@pytest.mark.parametrize("over", [VARIANTS["ipi-clamp-narrow"], EXTREME],
                         ids=["ipi-clamp-narrow", "extreme"])
def test_hostile_codes_saturate_without_undefined_behaviour(over, tmp_path):
    """The extreme codes as measurement, setpoint and manual output, under
    -fsanitize=undefined: every output is within the output limits, a measurement outside
    the input limits is held and counted."""
    ctrl = controller(over)
    sc = q31_intelligent(ctrl).scales
    src = c_source(ctrl, real="q31")
    big, y_lo, y_hi = 2**31 - 1, *sc.y_limits
    values = [-big - 1, -big, -1, 0, 1, big, y_lo, y_hi, y_lo - 1, y_hi + 1]
    rng = np.random.default_rng(5)
    rows = [[0, a, b] for a in values for b in values]
    rows += [[0, int(a), int(b)] for a, b in rng.integers(-2**31, 2**31, (300, 2))]
    rows += [[1, big, 0], [0, 0, 0], [2, 0, 0], [0, 0, big], [0, y_hi, -big - 1],
             [1, -big - 1, 0], [2, 0, 0], [0, y_lo, big], [0, y_hi, -big - 1]]
    exe = build(src, tmp_path, ("-fsanitize=undefined", "-fno-sanitize-recover=all"))
    out, nan_count = run(exe, np.array(rows, np.int64))
    assert np.all((out >= sc.u_limits[0]) & (out <= sc.u_limits[1]))
    outside = sum(1 for op, a, _ in rows if op == 0 and not y_lo <= a <= y_hi)
    assert nan_count == outside


def test_the_products_are_exact_where_they_can_be_checked(tmp_path):
    """The split 64-bit product against Python's integers: x M 2^(F - s) rounded to
    nearest (ties up), saturated to +-2^59, over random operands and every shift."""
    src = c_source(controller({}), real="q31")
    helpers = src.source.split("static int64_t mfc_limit")[0]
    rng = np.random.default_rng(11)
    cases = []
    for s in range(-15, 63):
        for _ in range(40):
            x = int(rng.integers(-2**40 + 1, 2**40))
            m = int(rng.integers(2**30, 2**31)) * int(rng.choice([-1, 1]))
            cases.append((x, m, s))
        cases += [(2**40 - 1, 2**31 - 1, s), (-2**40 + 1, -(2**31 - 1), s), (0, 2**30, s)]
    body = "\n".join(f"    printf(\"%lld\\n\", (long long)mfc_mul({x}LL, {m}LL, {s}));"
                     for x, m, s in cases)
    (tmp_path / "mfc.h").write_text(src.header)
    (tmp_path / "t.c").write_text(f"#include <stdio.h>\n{helpers}\nint main(void)\n{{\n"
                                  f"{body}\n    return 0;\n}}\n")
    exe = tmp_path / "t"
    subprocess.run([H.compiler(), *H.CFLAGS, "-Wno-unused-function", "-fsanitize=undefined",
                    "-fno-sanitize-recover=all", "-I", str(tmp_path), str(tmp_path / "t.c"),
                    "-o", str(exe)], check=True, timeout=600)
    got = [int(v) for v in subprocess.run([str(exe)], capture_output=True, text=True,
                                          check=True, timeout=600).stdout.split()]
    t_max = 2**59
    for (x, m, s), value in zip(cases, got, strict=True):
        r = s - GUARD_BITS
        exact = x * m * 2**-r if r <= 0 else (x * m + 2**(r - 1)) >> r
        assert value == max(-t_max, min(t_max, int(exact))), (x, m, s)


def test_the_cortex_m0_computes_the_same_codes(tmp_path):
    _require_tools()
    ctrl = controller(VARIANTS["ipid-order2-held-back-calculation"])
    src = c_source(ctrl, real="q31")
    ops = codes_of_the_run(ctrl)[:400]
    x86, _ = run(build(src, tmp_path / "x86"), ops)
    assert m0_codes(src, ops, tmp_path / "m0") == x86.tolist()


def test_what_the_fixed_point_export_cannot_hold_is_refused():
    with pytest.raises(ConfigError, match="input_limits"):
        c_source(mfcontrol.make_controller(CASE), real="q31")
    with pytest.raises(ConfigError, match="estimator.*backward-difference estimator only"):
        c_source(controller({"controller.estimator": "algebraic", "controller.window": 20}),
                 real="q31")
    with pytest.raises(ConfigError, match="gain.*constant gain only"):
        c_source(controller({"controller.adapt": "variational"}), real="q31")
    with pytest.raises(ConfigError, match="k_aw"):
        c_source(controller({"controller.anti_windup": "back-calculation",
                             "controller.k_aw": 5000.0}), real="q31")
    # a coefficient out of range is named by the parameter as given
    with pytest.raises(ConfigError, match=r"alpha = 1e-12: gives the q31 coefficient"):
        c_source(controller({"controller.alpha": 1e-12}), real="q31")
    with pytest.raises(ConfigError, match="q31.*i-PID"):
        c_source(mfcontrol.make_controller("motor-noise-adrc"), real="q31")
    assert math.isfinite(code(-1e300, 1.0))


# --- the tunable build (PREFIX_set_params) ---------------------------------------------

@pytest.mark.parametrize("name", list(VARIANTS))
def test_the_tunable_build_gives_the_frozen_builds_codes(name, tmp_path):
    """The coefficients and limits read from the parameter struct (the derivative and the
    back-calculation's integral test at run time) give the frozen build's codes."""
    ctrl = controller(VARIANTS[name])
    ops = codes_of_the_run(ctrl)
    tunable, _ = run(build(c_source(ctrl, real="q31"), tmp_path / "t"), ops)
    frozen_src = c_source(ctrl, real="q31", frozen=True)
    assert "set_params" not in frozen_src.header
    frozen, _ = run(build(frozen_src, tmp_path / "f"), ops)
    assert tunable.tolist() == frozen.tolist()


#: (variant, the retune): new gains, alpha and limits within the output scale; the
#: back-calculation's integral turned off (its anti-windup then does nothing, as in the
#: double law)
RETUNES = [("ipi-clamp", {"controller.kp": 40.0, "controller.ki": 80.0,
                          "controller.alpha": 40.0, "controller.duty_min": -6.0,
                          "controller.duty_max": 6.0}),
           ("ipid-order2-held-back-calculation", {"controller.ki": 0.0, "controller.kd": 0.3,
                                                  "controller.k_aw": 10.0})]


@pytest.mark.parametrize("name,changes", RETUNES, ids=[n for n, _ in RETUNES])
def test_set_params_restarts_bumplessly_on_the_new_coefficients(name, changes, tmp_path):
    """In automatic mode a new set restarts the law from the last output clamped to the
    new limits (held for the order's samples), as a return from manual does: the codes
    after it are those of the same export put in manual at the last output, given the set
    there and put back in automatic. The double law retuned at the same sample stays
    within 1e-4 of the output range."""
    from mfcontrol.cexport.fixed_point import fixed_params_c

    ctrl, new = controller(VARIANTS[name]), controller({**VARIANTS[name], **changes})
    steps = codes_of_the_run(ctrl)
    steps = steps[steps[:, 0] == 0]
    k = 400
    out, _ = run(build(c_source(ctrl, real="q31"), tmp_path / "a",
                       sets=[fixed_params_c(new, like=ctrl)]),
                 np.vstack([steps[:k], [[3, 0, 0]], steps[k:]]))
    assert out[k] == 0  # taken
    before, after = out[:k], out[k + 1:]
    taken = before[steps[:k, 1] <= q31_intelligent(ctrl).scales.y_limits[1]]
    manual, _ = run(build(c_source(ctrl, real="q31"), tmp_path / "c",
                          sets=[fixed_params_c(new, like=ctrl)]),
                    np.vstack([[[1, taken[-1], 0], [3, 0, 0], [2, 0, 0]], steps[k:]]))
    assert manual[0] == 0 and after.tolist() == manual[1:].tolist()
    # the double law, retuned at the same sample
    sc = q31_intelligent(ctrl).scales
    py = type(ctrl)(**ctrl._params)
    keys = {"controller.duty_min": "duty_min", "controller.duty_max": "duty_max"}
    retune = {keys.get(key, key.removeprefix("controller.")): v for key, v in changes.items()}
    if "duty_min" in retune:
        retune["output_limits"] = (retune.pop("duty_min"), retune.pop("duty_max"))
    u = []
    for i, (_, y, r) in enumerate(steps):
        if i == k:
            py.retune(**retune)
        u.append(py(y * sc.y_scale / 2**31, setpoint=r * sc.y_scale / 2**31))
    u_q = np.concatenate([before, after]) * sc.u_scale / 2**31
    assert np.max(np.abs(u_q - np.array(u))) < 1e-4 * (sc.u_hi - sc.u_lo)


def test_a_refused_parameter_set_changes_nothing_and_names_its_member(tmp_path):
    """A set for other formats, an alpha <= 0, a shift the split product cannot take,
    k_aw h above 1 and limits out of order are refused with their member's number; the
    codes go on as if no call had been made; an unchanged set is taken and changes
    nothing."""
    from mfcontrol.cexport.fixed_point import fixed_params_c

    from .test_fixed_point import initializer, members

    ctrl = controller(VARIANTS["ipid-order2-held-back-calculation"])
    good = members(fixed_params_c(ctrl))
    names = ["format", "cn", "cp", "cd", "ci", "caw", "out_min", "out_max"]
    assert len(good) == len(names)
    bad = {"format": "0x1UL", "cn": "{-1073741824L, 20}", "cp": "{1073741824L, -16}",
           "cd": "{1073741824L, 63}", "ci": "{1073741823L, 20}",
           "caw": "{1073741825L, 30}", "out_max": "-2147483647L"}
    sets = []
    for name, value in bad.items():
        values = list(good)
        values[names.index(name)] = value
        sets.append(initializer(values))
    sets.append(initializer(good))
    steps = codes_of_the_run(ctrl)
    steps = steps[steps[:, 0] == 0][:300]
    calls = [[3, i, 0] for i in range(len(sets))]
    out, _ = run(build(c_source(ctrl, real="q31"), tmp_path / "t", sets=sets),
                 np.vstack([steps[:100], calls, steps[100:]]))
    assert out[100:100 + len(calls)].tolist() == [names.index(n) + 1 for n in bad] + [0]
    alone, _ = run(build(c_source(ctrl, real="q31"), tmp_path / "a"), steps)
    assert np.concatenate([out[:100], out[100 + len(calls):]]).tolist() == alone.tolist()
    # a set for an export of another law or structure is refused in Python (review: an
    # IPI's for an IP's export was taken; a PID's like= an IPI's raised an IndexError)
    with pytest.raises(ConfigError, match="a set is for an export of its own law"):
        fixed_params_c(ctrl, like=controller(VARIANTS["ipi-clamp"]))
    with pytest.raises(ConfigError, match="a set is for an export of its own law"):
        fixed_params_c(controller(VARIANTS["ipi-clamp"]),
                     like=mfcontrol.PID(kp=1.0, ki=1.0, sample_time=ctrl.sample_time,
                                        output_limits=(-24, 24), input_limits=INPUT_LIMITS))
    trapezoid = controller({**VARIANTS["ipid-order2-held-back-calculation"],
                            "controller.kernel": "trapezoid"})
    with pytest.raises(ConfigError, match="structure of the export"):
        fixed_params_c(ctrl, like=trapezoid)


def test_extreme_valid_parameter_sets_keep_every_code_defined(tmp_path):
    """Sets at the ends of what the setter takes (mantissas +-(2^31 - 1), shifts -15 and
    62, k_aw h = 1, limits +-(2^31 - 1)), driven with hostile codes and rejected samples
    under -fsanitize=undefined: no overflow, every output within the limits."""
    from mfcontrol.cexport.fixed_point import fixed_params_c

    from .test_fixed_point import initializer, members

    ctrl = controller(VARIANTS["ipid-order2-held-back-calculation"])
    fmt = members(fixed_params_c(ctrl))[0]
    big = 2**31 - 1
    extremes = [
        [fmt, f"{{{big}L, -15}}", f"{{-{big}L, -15}}", f"{{{big}L, -15}}",
         f"{{-{big}L, -15}}", "{1073741824L, 30}", f"-{big}L", f"{big}L"],
        [fmt, "{1073741824L, 62}", f"{{{big}L, 62}}", f"{{-{big}L, 62}}", f"{{{big}L, 62}}",
         f"{{{big}L, 62}}", "0L", "0L"],
    ]
    sc = q31_intelligent(ctrl).scales
    values = [-big - 1, -big, -1, 0, 1, big, sc.y_limits[0], sc.y_limits[1]]
    rows = []
    for i in range(len(extremes)):
        rows += [[3, i, 0]] + [[0, a, b] for a in values for b in values]
        rows += [[1, big, 0], [0, 0, 0], [2, 0, 0], [0, big, -big - 1], [0, 0, big]]
    exe = build(c_source(ctrl, real="q31"), tmp_path,
                ("-fsanitize=undefined", "-fno-sanitize-recover=all"),
                sets=[initializer(e) for e in extremes])
    out, _ = run(exe, np.array(rows, np.int64))
    per = len(out) // len(extremes)  # an answer, then the steps' codes
    assert out[::per].tolist() == [0] * len(extremes)  # every extreme set taken
    assert not out[per + 1:].any()  # limits (0, 0): every output is 0


def _after_a_long_gap(ctrl, before, gap, y, r, tmp_path):
    """The q31 and double outputs for ``before`` (y, r) samples, ``gap`` - 1 rejected
    ones, then 5 samples of (y, r)."""
    sc = q31_intelligent(ctrl).scales
    qy, qu = sc.y_scale / 2**31, sc.u_scale / 2**31
    ops = np.array([[0, code(a, sc.y_scale), code(b, sc.y_scale)] for a, b in before]
                   + [[0, sc.y_limits[1] + 1, 0]] * (gap - 1)
                   + [[0, code(y, sc.y_scale), code(r, sc.y_scale)]] * 5, np.int64)
    out, _ = run(build(c_source(ctrl, real="q31"), tmp_path), ops)
    py = type(ctrl)(**ctrl._params)
    u = np.array([py(a * qy, setpoint=b * qy) for _, a, b in ops])
    after = slice(len(before) + gap - 1, None)  # the step after the gap, and the next
    return out[after] * qu, u[after]


def test_a_term_over_a_long_gap_saturates_only_where_the_double_laws_does(tmp_path):
    """Review: after d - 1 rejected samples the step saturated the difference term at 256
    times the limits, then divided it by d^n. Order 2, a gap of 64 periods over a
    30-unit setpoint step: +1.85 where the double law gives +4.01, the error carried on;
    order 1, 255 rejected then y from -0.1 to 40: -0.2, -0.4... where the double law
    gives -24. The quotient is now formed before it saturates."""
    ipi = mfcontrol.IPI(alpha=2000.0, kp=20.0, ki=50.0, sample_time=0.001, order=2,
                        output_limits=(-24.0, 24.0), input_limits=INPUT_LIMITS)
    q, u = _after_a_long_gap(ipi, [(0.0, 0.0)] * 10, 64, 0.0, 30.0, tmp_path / "2")
    assert np.abs(u).max() > 1.0  # (a step the law answers)
    np.testing.assert_allclose(q, u, atol=1e-5)
    ip = mfcontrol.IP(alpha=2.0, kp=0.01, sample_time=0.001, output_limits=(-24.0, 24.0),
                      input_limits=INPUT_LIMITS)
    q, u = _after_a_long_gap(ip, [(-0.01 * k, 0.0) for k in range(10)], 256, 40.0, 0.0,
                             tmp_path / "1")
    assert u[0] == -24.0
    np.testing.assert_allclose(q, u, atol=1e-5)
