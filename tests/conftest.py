from pathlib import Path

import pytest

DATA = Path(__file__).parent / "data"


@pytest.fixture(scope="session")
def published_reference():
    import pandas as pd

    return pd.read_csv(DATA / "published_voltage_standard_dR1.csv.gz")
