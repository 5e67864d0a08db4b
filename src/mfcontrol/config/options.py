"""Every configuration option, declared once: key, kind, default, check, meaning and the
fidelity preset it belongs to. Validation (:mod:`.resolve`), the user guide's option table
(:func:`options_markdown`, in ``docs/guide/options.md``) and ``mfcontrol show`` read this one table.
"""

from __future__ import annotations

import inspect
import re
import textwrap
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from .toml import toml_value

FIDELITIES = ("published", "paper")

#: a description's length at most (characters): some 7 times the longest built-in case's
#: (263), and a figure's title shows the first TITLE_MOST of it; a 10 MB one took minutes
#: to lay out as a title
MAX_DESCRIPTION = 2_000

#: characters of a description a figure's title shows at most: three lines of 95 (the
#: longest built-in case's fits)
TITLE_MOST = 3 * 95

#: load change times at most: a study has a handful (the paper's cases two), and each is
#: a plant event of every member and a mark on the figures; 1,000 draw in under a second
#: (as one collection of ticks), 1.5 million hung sweeps and tuning
MAX_CHANGE_TIMES = 1_000

#: the lti model's transfer-function degree at most (plant.den; plant.num has at most as
#: many coefficients). The model's poles are fixed by plant.den's coefficients in double
#: precision, whose conditioning grows exponentially with the degree: an n-fold pole
#: moves by about eps^(1/n) (numpy's roots of (s + 1)^20's exact coefficients are up to
#: 0.4 from -1; at 8, the benchmark's lag, 0.02), and the poles -1 .. -n of Wilkinson's
#: polynomial keep 3 digits at n = 20 and turn complex at 24: beyond 20, coefficients
#: are noise, not a model (a state space is not limited so). Each new degree is also
#: compiled afresh, once per machine: seconds up to 25, 2 minutes at 50, more at 400
MAX_TF_DEGREE = 20


@dataclass(frozen=True)
class Option:
    key: str
    kind: str  # "float", "str", "bool", "floats"
    default: Any
    doc: str
    choices: tuple[str, ...] = ()
    check: str = ""  # "positive", "nonnegative", "fraction", "" (any finite)
    preset: Mapping[str, Any] = field(default_factory=dict)


def _o(key, kind, default, doc, choices=(), check="", preset=None) -> Option:
    return Option(key, kind, default, doc, tuple(choices), check, preset or {})


OPTIONS: tuple[Option, ...] = (
    _o("description", "str", "", "one line describing the case (at most "
       f"{MAX_DESCRIPTION:,} characters; a figure's title shows the first {TITLE_MOST})"),
    _o("fidelity", "str", "published", "preset for the options below that differ between the "
       "published code and the printed equations; paper sets the printed plant coupling, "
       "gamma integrator and rate term, and keeps the published P term on y_{k-1} "
       "(controller.p_sample), derivative divisor (controller.deriv_scale) and gamma on "
       "the derivative error (controller.gain)", FIDELITIES),
    # plant
    _o("plant.model", "str", "buck", "plant model: averaged buck or boost converter, "
       "y' = a y + b u + w, a DC motor's speed under its armature voltage, or a transfer "
       "function (lti: plant.num / plant.den)", ("buck", "boost", "first-order", "dc-motor",
                                                  "lti")),
    _o("plant.output", "str", "voltage", "converters' measured output: v_C, or v_C * i_L "
       "(buck)", ("voltage", "power")),
    _o("plant.coupling", "str", None, "buck input coupling: the published code adds E d/L to "
       "dv/dt as well", ("published", "textbook"),
       preset={"published": "published", "paper": "textbook"}),
    _o("plant.E", "float", 20.0, "input voltage (V)", check="positive"),
    _o("plant.L", "float", 1e-3, "inductance (H)", check="positive"),
    _o("plant.R", "float", 10.0, "load resistance (ohm)", check="positive"),
    _o("plant.C", "float", 10e-6, "capacitance (F)", check="positive"),
    _o("plant.dR", "float", 1.0, "resistance added at each load change (ohm)"),
    _o("plant.dC", "float", 1e-9, "capacitance added at each load change (F)"),
    _o("plant.change_times", "floats", [4e-3, 6e-3], "load change times (s): applied at the "
       "first sample t_k >= each time, before that sample's plant step; at most "
       f"{MAX_CHANGE_TIMES:,} (a study has a handful)", check="nonnegative"),
    _o("plant.i0", "float", 0.0, "initial inductor (armature) current (A)"),
    _o("plant.v0", "float", 0.0, "initial capacitor voltage (V)"),
    _o("plant.a", "float", -1.0, "first-order: pole a (1/s)"),
    _o("plant.b", "float", 1.0, "first-order: input gain b"),
    _o("plant.w", "float", 0.0, "first-order: disturbance w"),
    _o("plant.y0", "float", 0.0, "first-order, dc-motor: initial output (the motor's "
       "speed, rad/s)"),
    _o("plant.J", "float", 5e-4, "dc-motor: rotor inertia (kg m^2)", check="positive"),
    _o("plant.friction", "float", 1e-4, "dc-motor: viscous friction (N m s)",
       check="nonnegative"),
    _o("plant.Km", "float", 0.05, "dc-motor: torque and back-emf constant (N m/A)",
       check="positive"),
    _o("plant.Ra", "float", 2.0, "dc-motor: armature resistance (ohm)", check="positive"),
    _o("plant.La", "float", 2e-3, "dc-motor: armature inductance (H)", check="positive"),
    _o("plant.load", "float", 0.0, "dc-motor: load torque (N m); a schedule steps it"),
    _o("plant.num", "floats", [1.0], "lti: numerator of G(s), coefficients in descending "
       "powers of s (strictly proper: fewer than plant.den's), at most "
       f"{MAX_TF_DEGREE + 1}"),
    _o("plant.den", "floats", [1.0, 1.0], "lti: denominator of G(s), descending powers of s, "
       f"the first nonzero; degree at most {MAX_TF_DEGREE} (beyond, double-precision "
       "coefficients no longer fix the poles: use mfcontrol.LTI's state space)"),
    _o("plant.gain", "float", 1.0, "lti: static gain K multiplying G(s) (a robustness axis)"),
    _o("plant.time_scale", "float", 1.0, "lti: every time constant multiplied by this, "
       "G(time_scale s) (a robustness axis)", check="positive"),
    _o("plant.schedule", "events", [], "parameter changes: a list of {t = time (s), name = "
       "parameter, set = value} or {..., add = delta}, applied at the first t_k >= t"),
    # reference
    _o("reference.kind", "str", "ramp-hold-ramp", "ramp-hold-ramp: min(slope t, level), "
       "then level + slope2 (t - t_ramp2) from t_ramp2 on; smooth-step: from initial to "
       "final along a half cosine over [t0, t0 + duration]",
       ("ramp-hold-ramp", "smooth-step")),
    _o("reference.slope", "float", 1000.0, "first slope (output unit/s)"),
    _o("reference.level", "float", 2.5, "hold level (output unit)"),
    _o("reference.t_ramp2", "float", None, "start of the second ramp (s); absent: none",
       check="nonnegative"),
    _o("reference.slope2", "float", 0.0, "second slope (output unit/s)"),
    _o("reference.initial", "float", 0.0, "smooth-step: value before t0"),
    _o("reference.final", "float", 1.0, "smooth-step: value after t0 + duration"),
    _o("reference.t0", "float", 0.0, "smooth-step: start (s)", check="nonnegative"),
    _o("reference.duration", "float", 0.0, "smooth-step: length (s); 0 for a plain step",
       check="nonnegative"),
    # controller
    _o("controller.law", "str", "ip", "ip: the paper's recursive i-P (eq. 8); variational: "
       "with the symplectic gamma update (eq. 33); i-P, i-PI, i-PD, i-PID: positional "
       "intelligent controllers; pid: the discrete PID of Astrom and Hagglund; adrc: "
       "linear active disturbance rejection control (extended state observer)",
       ("ip", "variational", "i-P", "i-PI", "i-PD", "i-PID", "pid", "adrc")),
    _o("controller.alpha", "float", 10.0, "key gain alpha of the ultra-local model (a "
       "variational gain starts from gamma0 instead)", check="positive"),
    _o("controller.kp", "float", 2.0, "proportional gain K_P"),
    _o("controller.ki", "float", 0.0, "i-PI, i-PID, pid: integral gain K_I"),
    _o("controller.kd", "float", 0.0, "i-PD, i-PID, pid: derivative gain K_D"),
    _o("controller.order", "int", 1, "positional laws: order n of y^(n) = F + alpha u; "
       "adrc: of y^(n) = f + b0 u", ("1", "2")),
    _o("controller.estimator", "str", "backward-difference", "positional laws: estimator of "
       "F", ("backward-difference", "algebraic")),
    _o("controller.window", "int", 20, "algebraic estimator: window M (samples; even for "
       "n = 2 with the trapezoid kernel)", check="positive"),
    _o("controller.kernel", "str", "held", "positional laws, algebraic estimator or n = 2: "
       "the estimator's discretisation; held: exact for a constant F under the held "
       "input (the i-P then has no steady-state error); trapezoid: the literature's "
       "trapezoid / Simpson rule and alpha u_{k-1}, half a sample out of line; "
       "delay-reduced (algebraic, n = 1): the held relations' weighted line at "
       "controller.lag samples back, exact for F affine in time",
       ("held", "trapezoid", "delay-reduced")),
    _o("controller.lag", "float", None, "delay-reduced kernel: the sample time the estimate "
       "belongs to, samples back from the newest (0, the default: none, for F affine in "
       "time; M/2 with kappa = mu = 1: the held kernel's), from 0 to M"),
    _o("controller.kappa", "int", 1, "delay-reduced kernel: the Jacobi weight's exponent "
       "at the newest end, w = (M/2 - x)^kappa (M/2 + x)^mu; whole, kappa + mu <= 2",
       check="nonnegative"),
    _o("controller.mu", "int", 1, "delay-reduced kernel: the Jacobi weight's exponent at "
       "the oldest end (controller.kappa)", check="nonnegative"),
    _o("controller.delay", "int", 0, "positional laws, adrc: the loop's input delay the "
       "law compensates (samples; the actuator's and sensor's together): F (adrc: its "
       "observer) is fed the input the plant received", check="nonnegative"),
    _o("controller.predict", "bool", False, "positional laws of order 1 with a "
       "compensated delay: the error predicted over the delay by the ultra-local model"),
    _o("controller.startup", "str", "hold", "algebraic estimator, until its window is "
       "full: hold the starting output for M samples, or let the backward difference "
       "stand in (stable only for alpha > beta (2 + K_P h) / 4)",
       ("hold", "backward-difference")),
    _o("controller.anti_windup", "str", "auto", "when the output is limited: the recursive "
       "laws' u (clamp: carry the limited value; back-calculation: a share k_aw h of the "
       "excess), the positional laws' integral; auto = none for the recursive laws (as "
       "published), clamp for the positional ones",
       ("auto", "clamp", "back-calculation", "none")),
    _o("controller.k_aw", "float", None, "back-calculation gain (1/s); absent: 1/sim.h",
       check="positive"),
    _o("controller.adapt", "str", "constant", "positional laws: gain adaptation (variational "
       "uses gamma0, Gamma, eps_M, integrator, adapt_every; rls estimates alpha online from "
       "controller.alpha, with forgetting, alpha_min, alpha_max)",
       ("constant", "variational", "rls")),
    _o("controller.forgetting", "float", 0.99, "rls: forgetting factor in (0, 1] (0.99 "
       "weighs about the last 100 samples, 1 all of them)"),
    _o("controller.alpha_min", "float", None, "rls: the estimate's lower clip (default "
       "controller.alpha / 10)"),
    _o("controller.alpha_max", "float", None, "rls: the estimate's upper clip (default "
       "10 controller.alpha)"),
    _o("controller.gamma0", "float", 1.0, "variational: initial gamma"),
    _o("controller.Gamma", "float", 5e-8, "variational: integrator gain Gamma (the paper "
       "states 5e-8; code v1.0.1 uses h^2/K_gamma = 1e-12 for single runs)"),
    _o("controller.eps_M", "float", 0.1, "variational: bound eps_M on |F_k - F_{k-1}|"),
    _o("controller.k_gamma", "float", 1.0, "variational: coupling K_gamma of the rate term"),
    _o("controller.adapt_every", "int", 1, "variational: update gamma every m control "
       "samples (the multi-rate integrator: macro step m h, the force averaged over it, "
       "Gamma scaled by m^order); 1 updates it at each sample", check="positive"),
    _o("controller.integrator", "str", None, "variational: gamma integrator order",
       ("first-order", "second-order"),
       preset={"published": "first-order", "paper": "second-order"}),
    _o("controller.rate_term", "bool", None, "variational: add K_gamma dgamma/dt to u "
       "(always 0 in the published code)", preset={"published": False, "paper": True}),
    _o("controller.rate_sign", "str", "plus", "sign of the rate term: plus as printed, minus "
       "as the published code writes it", ("plus", "minus")),
    _o("controller.gain", "str", None, "what multiplies the derivative error: gamma_k, or "
       "1/alpha (eq. 33 taken literally)", ("gamma", "alpha"),
       preset={"published": "gamma", "paper": "gamma"}),
    _o("controller.deriv_scale", "float", 1e-3, "divisor of the backward differences "
       "(published 1e-3; the paper writes h)", check="positive"),
    _o("controller.output_gain", "float", 1 / 2000, "duty = clip(output_gain * u)",
       check="positive"),
    _o("controller.duty_min", "float", 1e-3, "lower output limit (the converters' duty; set "
       "it for any other plant: a motor's voltage, say)"),
    _o("controller.duty_max", "float", 0.9, "upper output limit (as duty_min)"),
    _o("controller.p_sample", "str", "previous", "measurement in the P term: y_{k-1} "
       "(published) or y_k (printed)", ("previous", "current")),
    _o("controller.p_error", "str", "r-y", "P term error: Kp (r - y) (published) or "
       "Kp (y - r) (printed; positive feedback for Kp > 0)", ("r-y", "y-r")),
    _o("controller.u0", "float", 1.0, "initial control u_0"),
    _o("controller.N", "float", 10.0, "pid: derivative filter, time constant Td / N",
       check="positive"),
    _o("controller.b", "float", 1.0, "pid: setpoint weight of the proportional term"),
    _o("controller.c", "float", 0.0, "pid: setpoint weight of the derivative (0: the "
       "derivative of the measurement alone)"),
    _o("controller.Tf", "float", 0.0, "pid: time constant of Astrom and Hagglund's "
       "second-order measurement filter 1 / (1 + s Tf + (s Tf)^2 / 2), s; 0: none",
       check="nonnegative"),
    _o("controller.Tt", "float", None, "pid: tracking time of back-calculation (s); absent: "
       "sqrt(Ti Td) with an integral and a derivative, else Ti", check="positive"),
    _o("controller.b0", "float", 1.0, "adrc: the input gain b0 of y^(n) = f + b0 u (a "
       "rough value; its sign the plant's)"),
    _o("controller.wc", "float", 1.0, "adrc: the controller's bandwidth (rad/s): the loop's "
       "n poles at -wc", check="positive"),
    _o("controller.wo", "float", 10.0, "adrc: the observer's bandwidth (rad/s): its n + 1 "
       "poles at -wo (commonly 3 to 10 wc)", check="positive"),
    # sensor, actuator, disturbance
    _o("sensor.noise", "str", "none", "measurement noise added to y (gaussian when "
       "sensor.noise_std is given without it)", ("none", "gaussian", "uniform")),
    _o("sensor.noise_std", "float", 0.0, "noise standard deviation (output unit); given "
       "without sensor.noise, the noise is gaussian", check="nonnegative"),
    _o("sensor.seed", "int", 0, "noise seed: the same seed gives the same noise in a single "
       "run, a sweep member and on a Dask worker", check="nonnegative"),
    _o("sensor.quantum", "float", 0.0, "measurement resolution: y rounds to the nearest "
       "multiple (0: none)", check="nonnegative"),
    _o("sensor.delay", "int", 0, "measurement delay (samples): y_meas[k] = y[k - delay]",
       check="nonnegative"),
    _o("actuator.delay", "int", 0, "actuation delay (samples): u_plant[k] = u[k - delay], 0 "
       "before", check="nonnegative"),
    _o("actuator.rate_limit", "float", 0.0, "largest rate of change of the plant's input "
       "(unit/s; 0: none)", check="nonnegative"),
    _o("disturbance.kind", "str", "none", "step: amplitude from t0 on; ramp: amplitude (t - "
       "t0); sine: amplitude sin(2 pi frequency (t - t0)); table: linear in times/values",
       ("none", "step", "ramp", "sine", "table")),
    _o("disturbance.at", "str", "input", "added to the plant's input, or to its output y",
       ("input", "output")),
    _o("disturbance.amplitude", "float", 0.0, "step size, ramp slope (per s) or sine "
       "amplitude"),
    _o("disturbance.t0", "float", 0.0, "start (s)", check="nonnegative"),
    _o("disturbance.frequency", "float", 0.0, "sine frequency (Hz)", check="nonnegative"),
    _o("disturbance.times", "floats", [], "table: times (s), nondecreasing",
       check="nonnegative"),
    _o("disturbance.values", "floats", [], "table: the disturbance at those times"),
    # simulation
    _o("sim.h", "float", 1e-6, "sample period of the controller and RK4 step (s)",
       check="positive"),
    _o("sim.substeps", "int", 1, "plant integration steps of sim.h / substeps per sample, "
       "the input held (1: the published loop)", check="positive"),
    _o("sim.integrator", "str", "rk4", "plant integration between samples: one RK4 step "
       "(published) or a compiled adaptive Dormand-Prince 5(4) (scipy's RK45 method, input "
       "held, rtol 1e-9, atol 1e-12), or exact: the zero-order-hold discretisation (lti and "
       "first-order)", ("rk4", "rk45", "exact")),
    _o("sim.t_end", "float", 0.01, "horizon (s); samples t_k = (k t_end)/N, N = t_end/h",
       check="positive"),
    _o("sim.diverge_above", "float", 1e12, "|y| above this (or any NaN/inf) ends a run as "
       "diverged", check="positive"),
    # metrics
    _o("metrics.settle_time", "float", 1e-3, "max |e| is taken over t >= this (s)",
       check="nonnegative"),
    _o("metrics.final_window", "float", 0.2, "settling window: the last fraction of the "
       "horizon", check="fraction"),
    _o("metrics.settled_tol", "float", 0.1, "settled if max |e| over the window <= this "
       "times max |y*|", check="positive"),
    # sweeps
    # benchmark set (mfcontrol benchmark)
    _o("benchmark.objective", "str", "iae", "what the benchmark's tuning of every controller "
       "on this plant minimises (a metric or a weighted sum, as mfcontrol tune --objective)"),
    _o("benchmark.pid", "strs", None, "benchmark: the PID's search space, KEY=LO:HI each"),
    _o("benchmark.ip", "strs", None, "benchmark: the i-P's search space, KEY=LO:HI each"),
    _o("benchmark.ipi", "strs", None, "benchmark: the i-PI's search space, KEY=LO:HI each"),
    _o("benchmark.adrc", "strs", None, "benchmark: the ADRC's search space, KEY=LO:HI each "
       "(none: the plant's benchmark has no ADRC)"),
    _o("benchmark.log", "strs", [], "benchmark: tuned keys searched on a log scale"),
    _o("benchmark.robustness", "strs", None, "benchmark: the plant changes of the robustness "
       "map, two KEY=SPEC axes (as mfcontrol sweep --grid)"),
    _o("sweep.key", "str", None, "sweep cases: the option every member varies"),
    _o("sweep.values", "floats", None, "sweep cases: its values, one member each"),
    _o("sweep.grid", "strs", None, "map cases: the grid `mfcontrol sweep` runs when given no "
       "--grid, as [\"KEY=SPEC\", ...]"),
)


BY_KEY: dict[str, Option] = {o.key: o for o in OPTIONS}


#: a swept option's quantity in words, with its unit where it has one of its own, for the
#: axes of figures (maps, sweeps); gains whose unit depends on the plant have none
LABELS: dict[str, str] = {
    "plant.E": "input voltage E (V)",
    "plant.L": "inductance L (H)",
    "plant.R": "load resistance R (ohm)",
    "plant.C": "capacitance C (F)",
    "plant.dR": "load change dR (ohm)",
    "plant.dC": "load change dC (F)",
    "plant.a": "plant pole a (1/s)",
    "plant.b": "plant input gain b",
    "plant.J": "rotor inertia J (kg m$^2$)",
    "plant.friction": "viscous friction (N m s)",
    "plant.Km": "motor constant Km (N m/A)",
    "plant.Ra": "armature resistance Ra (ohm)",
    "plant.La": "armature inductance La (H)",
    "plant.load": "load torque (N m)",
    "plant.gain": "process gain, times nominal",
    "plant.time_scale": "process time scale, times nominal",
    "controller.alpha": "ultra-local model gain alpha",
    "controller.kp": "proportional gain K_P",
    "controller.ki": "integral gain K_I",
    "controller.kd": "derivative gain K_D",
    "controller.gamma0": "initial adaptive gain gamma0",
    "controller.Gamma": "adaptation step Gamma",
    "controller.eps_M": "adaptation level eps_M",
    "controller.k_gamma": "rate-term coupling K_gamma",
    "controller.window": "estimator window M (samples)",
    "controller.k_aw": "anti-windup gain k_aw (1/s)",
    "controller.b0": "ADRC input gain b0",
    "controller.wc": "ADRC controller bandwidth wc (rad/s)",
    "controller.wo": "ADRC observer bandwidth wo (rad/s)",
    "controller.N": "PID derivative filter N",
    "controller.b": "PID setpoint weight b",
    "controller.c": "PID derivative setpoint weight c",
    "controller.Tf": "PID measurement filter Tf (s)",
    "controller.Tt": "PID tracking time Tt (s)",
    "sensor.noise_std": "sensor noise, standard deviation (output unit)",
    "sensor.delay": "measurement delay (samples)",
    "actuator.delay": "actuator delay (samples)",
    "disturbance.amplitude": "disturbance amplitude",
}


def label(key: str) -> str:
    """A key's quantity in words for a figure's axis (:data:`LABELS`), else the key."""
    return LABELS.get(key, key)


def numpydoc_parameters(keys: Sequence[str]) -> str:
    """A numpydoc ``Parameters`` section for the options ``keys``, each parameter named
    by its key's last part: the classes that take options as keywords (the loop's
    elements, RecursiveIP) document them from here, where they are declared."""
    kinds = {"float": "float", "int": "int", "str": "str", "bool": "bool",
             "floats": "sequence of float", "strs": "sequence of str",
             "events": "sequence of dict"}
    lines = ["Parameters", "----------"]
    for key in keys:
        o = BY_KEY[key]
        kind = "{" + ", ".join(repr(c) for c in o.choices) + "}" if o.choices else kinds[o.kind]
        # the docs are plain text: |e| would be an rST substitution, `x` interpreted text
        text = re.sub(r"\|[^|]+\|", lambda m: f"``{m.group(0)}``",
                      re.sub(r"(?<!`)`([^`]+)`(?!`)", r"``\1``", o.doc))
        lines.append(f"{key.split('.', 1)[1]} : {kind}")
        lines += textwrap.wrap(text if text.endswith(".") else text + ".", 84,
                               initial_indent="    ", subsequent_indent="    ")
    return "\n".join(lines)


def with_parameters(doc: str | None, parameters: str) -> str:
    """``doc`` with the section ``parameters`` put before its Examples (or at its end)."""
    head, sep, examples = inspect.cleandoc(doc or "").partition("Examples\n")
    return f"{head.rstrip()}\n\n{parameters}\n\n{sep}{examples}".rstrip() + "\n"


def allowed(o: Option) -> str:
    if o.choices:
        return "must be one of " + ", ".join(o.choices)
    return {
        "float": {"positive": "must be a finite number > 0",
                  "nonnegative": "must be a finite number >= 0",
                  "fraction": "must be a number in (0, 1]",
                  "": "must be a finite number"}[o.check],
        "floats": "must be a list of finite numbers" + (" >= 0" if o.check else ""),
        "int": "must be a whole number" + {"positive": " > 0",
                                           "nonnegative": " >= 0"}.get(o.check, ""),
        "strs": "must be a list of strings",
        "events": "must be a list of tables {t = time >= 0, name = parameter, set = value} "
                  "or {t, name, add = delta}",
        "bool": "must be true or false",
        "str": "must be a string",
    }[o.kind]


#: parameters a schedule may change, per plant model
PLANT_PARAMETERS = {"buck": ("E", "L", "R", "C"), "boost": ("E", "L", "R", "C"),
                    "first-order": ("a", "b", "w"),
                    "dc-motor": ("J", "friction", "Km", "Ra", "La", "load"), "lti": ()}


#: the positional intelligent laws (the others are the paper's recursive law)
POSITIONAL = ("i-P", "i-PI", "i-PD", "i-PID")


def gain_adapts(cfg: Mapping[str, Any]) -> bool:
    """Whether a configuration's gain adapts by the variational law (the paper's
    variational law, or a positional law with ``controller.adapt = "variational"``): where
    gamma moves and the metric ``adaptation_error`` applies."""
    return cfg["controller.law"] == "variational" or (
        cfg["controller.law"] in POSITIONAL and cfg["controller.adapt"] == "variational")


def options_markdown() -> str:
    """The option table of the user guide (``docs/guide/options.md``), generated from
    :data:`OPTIONS`."""
    def default(o: Option) -> str:
        if o.preset:
            return " / ".join(f"{f}: `{toml_value(v)}`" for f, v in o.preset.items())
        return "none" if o.default is None else f"`{toml_value(o.default)}`"

    rows = ["| key | default | allowed | meaning |", "|---|---|---|---|"]
    for o in OPTIONS:
        what = allowed(o).removeprefix("must be ").replace("|", "\\|")
        rows.append(f"| `{o.key}` | {default(o)} | {what} | {o.doc.replace('|', '/')} |")
    return "\n".join(rows)
