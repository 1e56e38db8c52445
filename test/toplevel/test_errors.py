"""Every exception class of gear_phm derives from the one package base, GearPhmError."""
from __future__ import annotations

import importlib
import inspect
import pkgutil

import pytest

import gear_phm
from gear_phm import GearPhmError
from gear_phm.bagio import BagReader


def _modules() -> list[str]:
    """Every module of the package that imports without rclpy's nodes running."""
    return [info.name for info in pkgutil.walk_packages(gear_phm.__path__, 'gear_phm.')]


def test_every_exception_class_derives_from_the_package_base() -> None:
    found = {}
    for name in _modules():
        module = importlib.import_module(name)
        for _, obj in inspect.getmembers(module, inspect.isclass):
            if (issubclass(obj, BaseException) and obj.__module__.startswith('gear_phm')):
                found[f'{obj.__module__}.{obj.__qualname__}'] = obj
    assert len(found) >= 14, sorted(found)
    outside = sorted(name for name, cls in found.items() if not issubclass(cls, GearPhmError))
    assert outside == []


def test_a_user_catches_any_gear_phm_error_from_the_api(tmp_path) -> None:
    missing = tmp_path / 'no-such-bag'
    with pytest.raises(GearPhmError, match='no-such-bag'):
        BagReader(missing).__enter__()
