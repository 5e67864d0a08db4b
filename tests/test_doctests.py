"""The runnable examples in the main entry points' docstrings run and are right."""

import doctest

import pytest

import mfcontrol.api.controllers
import mfcontrol.api.interop
import mfcontrol.api.loop
import mfcontrol.api.objective
import mfcontrol.api.plants
import mfcontrol.api.simulate
import mfcontrol.api.sweep
import mfcontrol.cexport.export
import mfcontrol.experiments.benchmark
import mfcontrol.experiments.cases
import mfcontrol.experiments.compare
import mfcontrol.experiments.tune

MODULES = [mfcontrol.api.controllers, mfcontrol.api.interop, mfcontrol.api.loop,
           mfcontrol.api.objective, mfcontrol.api.plants, mfcontrol.api.simulate,
           mfcontrol.api.sweep, mfcontrol.cexport.export, mfcontrol.experiments.benchmark,
           mfcontrol.experiments.cases, mfcontrol.experiments.compare,
           mfcontrol.experiments.tune]


@pytest.mark.parametrize("module", MODULES, ids=lambda m: m.__name__)
def test_docstring_examples(module):
    failed, attempted = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert attempted > 0 and failed == 0
