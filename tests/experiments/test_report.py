"""report.md's prose: every sentence computed from the runs it describes (issue 14 item 12)."""

import re

import numpy as np
import pandas as pd
import pytest

from mfcontrol.experiments import report
from mfcontrol.experiments.reproduce import long_horizon


@pytest.fixture(scope="module")
def horizons():
    return {fid: long_horizon(fid) for fid in ("paper", "published")}


def _paragraphs(fid, horizons):
    text = "\n".join(report._horizon_section([fid], {fid: horizons[fid]}))
    return [p for p in text.split("\n\n") if "integrator:" in p]


def test_a_failed_loop_is_not_described_by_the_drift_law(horizons):
    # printed equations, second-order integrator: both loops fail and gamma turns back and
    # forth; the report said "gamma drifts quadratically ... by -12.8 ... against -25"
    # (-12.8 the mean of the two runs' final gammas)
    paras = _paragraphs("paper", horizons)
    failed = [p for p in paras if "second-order" in p]
    assert len(failed) == 2
    for p, (_, _, r) in zip(failed, [h for h in horizons["paper"] if h[1] == "second-order"],
                            strict=True):
        assert not r.metrics["stable"]
        assert "the loop fails" in p and "drifts" not in p and "-12.8" not in p
        assert report._fmt(r.signals["gamma"][-1]) in p  # its own final gamma
    held = [p for p in paras if "first-order" in p]
    assert all("drifts linearly" in p for p in held)


def test_a_held_loop_states_the_drift_it_measured(horizons):
    for p, (_, order, r) in zip(_paragraphs("published", horizons), horizons["published"],
                            strict=True):
        assert r.metrics["stable"]
        shape = "linearly" if order == "first-order" else "quadratically"
        assert f"drifts {shape}" in p
        drift = r.signals["gamma"][-1] - r.config["controller.gamma0"]
        assert f"by {report._fmt(drift)}" in p
        assert ("reaches zero" in p) == bool((r.signals["gamma"] <= 0).any())


def _map(stable):
    gammas, eps = np.logspace(-10, -5, 11), np.logspace(-5, 3, 17)
    G, E = np.meshgrid(gammas, eps, indexing="ij")
    return pd.DataFrame({"controller.Gamma": G.ravel(), "controller.eps_M": E.ravel(),
                         "stable": stable(G, E).ravel()})


def test_the_gamma_eps_boundary_is_described_not_its_corners():
    # stable below Gamma eps_M = 1e-8 while Gamma < 2e-6, unstable above that Gamma:
    # the report named the smallest unstable Gamma and eps_M (two grid corners)
    text = report.gamma_eps_boundary(_map(lambda G, E: (G * E < 1e-8) & (G < 2e-6)))
    product = float(re.search(r"follows Gamma eps_M = ([0-9.e+-]+) ", text).group(1))
    assert 1e-8 / 10 ** 0.5 <= product <= 1e-8 * 10 ** 0.5  # within one eps_M grid step
    assert "from 3.16e-06 to 1e-05 is unstable at every eps_M" in text
    assert "smallest" not in text


def test_rows_stable_everywhere_and_rows_that_alternate_are_said():
    text = report.gamma_eps_boundary(_map(lambda G, E: (G < 1e-9) | ((E > 1) & (E < 10))))
    assert "from 1e-10 to 3.16e-10 is stable at every eps_M" in text
    assert "alternate along eps_M" in text
    text = report.gamma_eps_boundary(_map(lambda G, E: E < 1e-3 + 0 * G))
    assert "does not follow a constant product" in text
