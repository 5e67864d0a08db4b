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
