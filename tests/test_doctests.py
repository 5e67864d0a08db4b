"""The runnable examples in the docstrings run and are right: every module of the package
that has one (found by walking the package, so a new module's examples are not left out,
as api/elements.py and api/display.py were from a list written by hand)."""

import doctest
import importlib
import pkgutil

import pytest

import mfcontrol


def _modules_with_examples() -> list[str]:
    names = []
    for info in pkgutil.walk_packages(mfcontrol.__path__, "mfcontrol."):
        module = importlib.import_module(info.name)
        if any(t.examples for t in doctest.DocTestFinder().find(module)):
            names.append(info.name)
    return names


MODULES = _modules_with_examples()


def test_the_main_entry_points_have_examples():
    for name in ("mfcontrol.api.model.controllers", "mfcontrol.api.run.loop",
                 "mfcontrol.api.run.sweep", "mfcontrol.api.model.elements",
                 "mfcontrol.api.results.display",
                 "mfcontrol.experiments.tune", "mfcontrol.cexport.export"):
        assert name in MODULES


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    failed, attempted = doctest.testmod(importlib.import_module(name),
                                        optionflags=doctest.ELLIPSIS)
    assert attempted > 0 and failed == 0
