import signal
from pathlib import Path

import pytest

DATA = Path(__file__).parent / "data"

# A shell starts a background job (``pytest &``, under nohup) with SIGINT ignored, and an
# ignored signal stays ignored in every process started from it: the tests that press
# Ctrl-C on a command would find the command deaf to it (seen: exit 0 and -9 instead of
# 130). The tests run as from a terminal, where Ctrl-C interrupts.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(scope="session")
def published_reference():
    import pandas as pd

    return pd.read_csv(DATA / "published_voltage_standard_dR1.csv.gz")


# --- counts that tests report (the fuzz tests' tallies), printed in the summary -----------
# A test calls record_property("counts", text); the property travels with the report from an
# xdist worker, and the summary prints it whatever captured the test's own output.
_COUNTS: list[tuple[str, str]] = []


def pytest_runtest_logreport(report):
    if report.when == "call":
        _COUNTS.extend((report.nodeid, value) for name, value in report.user_properties
                       if name == "counts")


def pytest_terminal_summary(terminalreporter):
    if _COUNTS:
        terminalreporter.section("counts")
        for nodeid, text in sorted(_COUNTS):
            terminalreporter.write_line(f"{nodeid}: {text}")


# --- the vectorised loop's kernels, compiled once for the workers of a run ----------------
def _warm_f(t, x, u, p, dxdt):
    dxdt[0] = x[1]
    dxdt[1] = u - p[0] * x[0] - p[1] * x[1]


def _warm_g(x, p):
    return x[0]


@pytest.fixture(scope="session")
def vectorised_kernels(tmp_path_factory):
    """The kernels of a single run and a vectorised sweep of an ODE plant in numba's disk
    cache. Compiling them takes minutes on a cold cache (a clean CI machine), and two xdist
    workers reaching them at once (or a test's child process) would each compile them:
    under a lock shared by the run's workers, one compiles them with a small run and sweep
    while another waits, then loads them, as a child process started afterwards does."""
    from filelock import FileLock

    import mfcontrol

    shared = tmp_path_factory.getbasetemp().parent  # the same for every worker of the run
    with FileLock(shared / "vectorised-kernels.lock"):
        plant = mfcontrol.ODE(_warm_f, _warm_g, x0=(0.0, 0.0), params={"k": 4.0, "c": 1.0})
        ctrl = mfcontrol.IPI(alpha=2.0, kp=4.0, ki=2.0, sample_time=1e-3)
        mfcontrol.simulate_loop(plant, ctrl, 1.0, t_end=0.01)
        mfcontrol.sweep(plant, ctrl, 1.0, t_end=0.01, vectorise=True,
                        grid={"controller.kp": [1.0, 2.0]})
