"""The examples in ur3dq's (and the polyscope_format package's) docstrings run as written (doctest), so what a
reader copies works."""
import doctest
import importlib
import pkgutil

import pytest

import polyscope_format
import ur3dq

MODULES = sorted(info.name for package in (ur3dq, polyscope_format)
                 for info in pkgutil.walk_packages(package.__path__, package.__name__ + ".")
                 if not info.name.endswith("__main__"))
WITH_EXAMPLES = [name for name in MODULES if ">>>" in (importlib.util.find_spec(name).loader.get_source(name) or "")]


def test_the_public_modules_show_examples():
    for module in ("ur3dq.dualquat", "ur3dq.pose", "ur3dq.store", "ur3dq.replay", "ur3dq.program.plan",
                   "ur3dq.pathcheck.path_check", "ur3dq.urscript.text"):
        assert module in WITH_EXAMPLES


@pytest.mark.parametrize("name", WITH_EXAMPLES)
def test_docstring_examples_run(name):
    module = importlib.import_module(name)
    failures, tried = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE,
                                      report=True)
    assert tried > 0 and failures == 0
