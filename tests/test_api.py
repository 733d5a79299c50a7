"""The top-level API: the main entry points under ``pressurepose``, loaded on first use."""

import subprocess
import sys

import pytest

import pressurepose


def test_every_entry_point_is_the_function_or_class_its_module_defines():
    import importlib

    for name, module in pressurepose._ENTRY_POINTS.items():
        assert getattr(pressurepose, name) is getattr(importlib.import_module(module), name)
        assert name in dir(pressurepose) and name in pressurepose.__all__


def test_importing_the_package_loads_neither_torch_nor_mujoco():
    code = ("import sys, pressurepose; assert 'torch' not in sys.modules and 'mujoco' not in sys.modules; "
            "pressurepose.estimate; assert 'torch' in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_an_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'estimat'"):
        pressurepose.estimat  # noqa: B018
    assert not hasattr(pressurepose, "settle")
