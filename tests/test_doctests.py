"""The runnable examples in the main entry points' docstrings run and are right."""

import doctest

import pytest

import mfcontrol.api.controllers
import mfcontrol.api.interop
import mfcontrol.api.loop
import mfcontrol.api.plants
import mfcontrol.api.simulate
import mfcontrol.api.sweep
import mfcontrol.experiments.cases

MODULES = [mfcontrol.api.controllers, mfcontrol.api.interop, mfcontrol.api.loop,
           mfcontrol.api.plants, mfcontrol.api.simulate, mfcontrol.api.sweep,
           mfcontrol.experiments.cases]


@pytest.mark.parametrize("module", MODULES, ids=lambda m: m.__name__)
def test_docstring_examples(module):
    failed, attempted = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert attempted > 0 and failed == 0
