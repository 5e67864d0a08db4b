"""Linearised closed-loop growth rates: the facts behind the stable/unstable verdicts."""

import pytest

from mfcontrol.experiments.cases import resolve_case
from mfcontrol.experiments.stability import growth_rate, spectral_radius


def _rate(fidelity, gain, R):
    cfg = resolve_case("voltage-stable-standard", {"fidelity": fidelity})[1]
    return growth_rate(spectral_radius(cfg, gain, R), cfg["sim.h"])


@pytest.mark.parametrize("R,grows", [(10, False), (11, False), (12, False), (15, True),
                                     (20, True)])
def test_published_plant_standard_ip(R, grows):
    assert (_rate("published", 0.1, R) > 0) is grows


@pytest.mark.parametrize("R", [10, 12, 20])
def test_textbook_plant_standard_ip_grows_even_at_nominal_load(R):
    assert _rate("paper", 0.1, R) > 0


@pytest.mark.parametrize("fidelity", ["published", "paper"])
@pytest.mark.parametrize("R", [10, 12, 20])
def test_gain_one_is_stable_everywhere(fidelity, R):
    assert _rate(fidelity, 1.0, R) < -1000


def test_a_growing_mode_shows_in_the_simulation():
    import mfcontrol

    r = mfcontrol.run_case("voltage-stable-standard", {"fidelity": "paper",
                                                         "plant.change_times": []})
    e = abs(r.error)
    early, late = e[(r.time > 2.5e-3) & (r.time < 4e-3)].max(), e[r.time > 8.5e-3].max()
    assert late > early
