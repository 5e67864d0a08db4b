"""The runnable examples in the main entry points' docstrings run and are right."""

import doctest

import pytest

import mfcontrol.experiments.cases


@pytest.mark.parametrize("module", [mfcontrol.experiments.cases])
def test_docstring_examples(module):
    failed, attempted = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert attempted > 0 and failed == 0
