"""Every docstring example in the package runs as written."""
import doctest
import importlib
import inspect
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


# Public names (in their module's __all__, defined there) whose docstrings still have no
# example because their files are being edited elsewhere.  This set must only shrink:
# never add a name to it -- give the new function or class an example instead.
PENDING = set()


def _public_names_without_example():
    """``module.name`` of every public function or class (in ``__all__``, defined in that module) with no ``>>>``."""
    missing = set()
    for name in MODULES:
        module = importlib.import_module(name)
        for attr in getattr(module, "__all__", []):
            obj = getattr(module, attr)
            if ((inspect.isfunction(obj) or inspect.isclass(obj)) and obj.__module__ == name
                    and ">>>" not in (obj.__doc__ or "")):
                missing.add(f"{name}.{attr}")
    return missing


def test_every_public_name_has_an_example():
    missing = _public_names_without_example()
    assert sorted(missing - PENDING) == [], "public names without a docstring example (add one)"
    assert sorted(PENDING - missing) == [], "these now have examples: remove them from PENDING"
