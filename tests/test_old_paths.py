"""The module paths of before the layer folders are gone: importing one fails at once, naming
the module (nothing was released with them, so no finder keeps them alive)."""

from __future__ import annotations

import importlib
import sys

import pytest

import tiseg


@pytest.mark.parametrize("old", ["tiseg.simulation", "tiseg.numerics.operator", "tiseg.sweep"])
def test_an_old_module_path_is_not_found(old):
    with pytest.raises(ModuleNotFoundError, match=old.split(".")[1]):
        importlib.import_module(old)


def test_importing_tiseg_adds_no_finder():
    mine = [f for f in sys.meta_path if type(f).__module__.startswith(tiseg.__name__)]
    assert not mine
