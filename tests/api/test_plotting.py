"""Figures that read like a paper's (issue 15): events named, coinciding curves said to
coincide, an outlier kept from flattening the others, titles in words."""

import dataclasses

import numpy as np

import mfcontrol
from mfcontrol.api.plotting import units


def _texts(fig):
    return [t.get_text() for ax in fig.axes for t in ax.texts] + \
        [ax.get_title(loc="left") for ax in fig.axes]


def test_a_run_names_its_events_and_its_case_in_words():
    r = mfcontrol.run_case("voltage-stable-standard")
    fig = r.plot()
    assert _texts(fig).count("load change") == 4  # two changes, two panels
    assert fig._suptitle.get_text().startswith("Voltage control, standard i-P")


def test_coinciding_members_are_drawn_once_and_said_to_coincide():
    sw = mfcontrol.run_case("sweep-Gamma")
    same = dataclasses.replace(sw, members=[sw.members[0]] * 3, values=[1.0, 2.0, 3.0])
    fig = same.plot(kind="gamma")
    ax = fig.axes[0]
    assert len(ax.get_lines()) == 1 + 2  # one curve, two event lines
    assert ax.get_legend().get_texts()[0].get_text() == "Gamma = 1, 2, 3 (coincide)"
    assert "all 3 members give the same curve" in _texts(fig)


def test_an_unstable_member_does_not_flatten_the_stable_ones():
    sw = mfcontrol.run_case("sweep-Gamma", {"fidelity": "paper"})
    assert not all(m.metrics["stable"] for m in sw.members)
    fig = sw.plot(kind="gamma")
    lo, hi = fig.axes[0].get_ylim()
    stable = np.concatenate([m.signals["gamma"] for m in sw.members if m.metrics["stable"]])
    assert lo <= stable.min() and stable.max() <= hi and hi - lo < 2 * np.ptp(stable)
    assert any(t.startswith("unstable members leave the axis") for t in _texts(fig))


def test_units_of_every_plant_family():
    from mfcontrol.experiments.cases import resolve_case

    assert units(resolve_case("voltage-stable-standard")[1]) == ("V", "1")
    assert units(resolve_case("power-standard")[1]) == ("W", "1")
    assert units(resolve_case("motor-noise-ipi")[1]) == ("rad/s", "V")


def test_members_that_coincide_on_the_scale_are_drawn_once():
    """Published choices: eps_M = 1e-5 and 0.1 give tracking errors within 3e-5 of the
    largest; they looked like one curve under two legend entries."""
    sw = mfcontrol.run_case("sweep-epsM")
    fig = sw.plot(kind="error")
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert labels == ["eps_M = 1e-05, 0.1 (coincide)", "eps_M = 1000"]
    assert "curves that coincide on this scale are drawn once" in _texts(fig)


def test_an_unstable_member_does_not_widen_what_counts_as_coinciding():
    """Printed equations: Gamma = 5e-10 and 5e-9 end at 0.998 and 0.973, apart on the
    stable members' axis; the unstable members' range (-194 .. 11) merged them."""
    sw = mfcontrol.run_case("sweep-Gamma", {"fidelity": "paper"})
    labels = [t.get_text() for t in sw.plot(kind="gamma").axes[0].get_legend().get_texts()]
    assert labels[:2] == ["Gamma = 5e-10", "Gamma = 5e-09"]
