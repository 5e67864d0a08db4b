import re

from mfcontrol.experiments.reproduce import SINGLE, SWEEPS, VARIATIONAL, reproduce


def test_reproduce_writes_every_figure_table_and_the_report(tmp_path):
    messages = []
    report = reproduce(tmp_path, ["published", "paper"], progress=messages.append)
    text = report.read_text()
    for fid in ("published", "paper"):
        d = tmp_path / fid
        for case in SINGLE:
            assert (d / f"{case}.png").stat().st_size > 10_000
            assert (d / f"{case}.csv").exists()
        for case in VARIATIONAL:
            assert (d / f"{case}-gamma.png").exists()
            assert (d / f"comparison-{case}.csv").exists()
        for case in SWEEPS:
            assert (d / f"{case}-gamma.png").exists() and (d / f"{case}-error.png").exists()
    for link in re.findall(r"\]\(([^)]+\.png)\)", text):
        assert (tmp_path / link).exists(), link
    assert "equal gain" in text and "as printed, gain = alpha" in text
    assert "## Where the paper and its published code disagree" in text
    for fid in ("published", "paper"):
        for name in ("map-alpha-dR.png", "map-Gamma-epsM.png", "long-horizon.png",
                     "long-horizon.csv", "map-alpha-dR-standard.csv"):
            assert (tmp_path / fid / name).exists(), name
    assert "## Robustness maps" in text and "## Long horizon" in text
    for fid in ("published", "paper"):
        for study in ("noise", "sample_time", "frozen", "symplectic", "operating_range"):
            assert (tmp_path / fid / f"claims-{study}.csv").exists(), study
    assert ("## The claims under noise, at a digital sample time, with the gain frozen, "
            "as a symplectic integrator, over the operating range") in text
    assert "Eq. (32) as printed is the Stormer-Verlet step" in text
    assert "The power output v_C i_L is a nonlinear map" in text
    assert len(messages) == 32 and messages[-1].startswith("[32/32]")
