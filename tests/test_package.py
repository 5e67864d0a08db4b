"""The package's top level: its public names load on first use, and quickly."""

import ast
import subprocess
import sys
from pathlib import Path

import mfcontrol


def test_every_public_name_resolves_and_type_checkers_see_the_same_names():
    init = Path(mfcontrol.__file__)
    tree = ast.parse(init.read_text())
    seen = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and getattr(node.test, "id", "") == "TYPE_CHECKING":
            for imp in node.body:
                seen |= {alias.asname or alias.name for alias in imp.names}
    assert seen == set(mfcontrol.__all__) - {"__version__"}
    for name in mfcontrol.__all__:
        assert getattr(mfcontrol, name) is not None
    assert set(mfcontrol.__all__) <= set(dir(mfcontrol))
    assert mfcontrol.case_names is mfcontrol.experiments.cases.names


def test_the_command_line_starts_without_the_numerical_stack():
    """`import mfcontrol.cli` took 1.6 s (numpy, scipy, numba): a Ctrl-C in that time was
    a traceback (issue 14 item 9), and --help/--version waited for it."""
    code = ("import sys, mfcontrol.cli; "
            "print(sorted(m for m in ('numpy', 'scipy', 'numba') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"


def test_subpackages_are_attributes_as_before():
    """The lazy top level dropped `mfcontrol.experiments` & co. (bench_c_export.py failed)."""
    code = ("import mfcontrol; print(mfcontrol.experiments.cases.names()[0], "
            "mfcontrol.laws.intelligent.N_PARAMS > 0)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.split()[1] == "True"


def test_every_public_name_documents_what_it_takes():
    """help() and the API pages describe every keyword (issue 15): a public class or
    function that takes any has a numpydoc Parameters (or Attributes) section."""
    import inspect

    bare = []
    for name in mfcontrol.__all__[1:]:
        obj = getattr(mfcontrol, name)
        try:
            taken = [p for p in inspect.signature(obj).parameters if p not in ("self",)]
        except ValueError:  # an exception class with the builtin constructor
            continue
        doc = inspect.getdoc(obj) or ""
        if taken and "\nParameters\n" not in doc and "\nAttributes\n" not in doc:
            bare.append(name)
    assert bare == []
