"""Every docstring example in the package runs as written."""
import doctest
import importlib
import pkgutil

import pytest

import tps_solver

MODULES = sorted(m.name for m in pkgutil.walk_packages(tps_solver.__path__, "tps_solver.")
                 if "._commands" not in m.name)


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0
