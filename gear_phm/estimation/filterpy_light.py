"""filterpy's ``KalmanFilter`` without importing the rest of filterpy (scipy.stats, scipy.linalg).

``import filterpy.kalman`` runs ``filterpy/__init__.py``, which imports every filterpy module;
``filterpy.stats`` and ``filterpy.common`` pull in ``scipy.stats`` and ``scipy.linalg``. That
took 1.2 s of a 1.6 s start-up of ``gear-phm analyze`` here (``python -X importtime``), for a
filter of which gear_phm uses ``predict`` and ``update`` only.

This module's ``KalmanFilter`` (imported by ``estimation/kalman.py``) is filterpy's own class,
loaded from ``kalman/kalman_filter.py`` (the library's code, unchanged) with just the two
helpers it needs at import time: ``pretty_str`` and ``reshape_z`` from
``filterpy/common/helpers.py`` (numpy only). ``logpdf``, used only by the
likelihood properties, imports ``filterpy.stats`` on its first call. The temporary module
entries are removed again, so a later ``import filterpy`` by anyone else is the full, normal
import. If filterpy's layout ever differs, the normal import is used instead (slower, never
wrong); test/estimation/test_filterpy_light.py holds the result to filterpy's own class.
"""
from __future__ import annotations

import importlib.util
from pathlib import Path
import sys
import types
from typing import Any

_NAMES = ('filterpy', 'filterpy.common', 'filterpy.stats')


def _logpdf(*args: Any, **kwargs: Any) -> Any:
    """filterpy.stats.logpdf, imported on first use (it needs scipy.stats)."""
    from filterpy.stats import logpdf
    return logpdf(*args, **kwargs)


def _load(name: str, path: Path) -> types.ModuleType:
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        msg = f'cannot load {path}'
        raise ImportError(msg)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _light_class() -> type:
    """Return filterpy's ``KalmanFilter`` loaded light; raises ImportError if it cannot be."""
    spec = importlib.util.find_spec('filterpy')
    if spec is None or spec.origin is None:
        msg = 'filterpy is not installed'
        raise ImportError(msg)
    root = Path(spec.origin).parent
    saved = {name: sys.modules.get(name) for name in _NAMES}
    try:
        helpers = _load('gear_phm._filterpy_helpers', root / 'common' / 'helpers.py')
        common = types.ModuleType('filterpy.common')
        common.pretty_str = helpers.pretty_str  # type: ignore[attr-defined]
        common.reshape_z = helpers.reshape_z  # type: ignore[attr-defined]
        stats = types.ModuleType('filterpy.stats')
        stats.logpdf = _logpdf  # type: ignore[attr-defined]
        sys.modules.update({'filterpy': types.ModuleType('filterpy'),
                            'filterpy.common': common, 'filterpy.stats': stats})
        module = _load('gear_phm._filterpy_kalman_filter', root / 'kalman' / 'kalman_filter.py')
    finally:
        for name, old in saved.items():
            if old is None:
                sys.modules.pop(name, None)
            else:
                sys.modules[name] = old
    light: type = module.KalmanFilter
    return light


def _kalman_filter_class() -> type:
    """Return filterpy's ``KalmanFilter`` class, loaded light when filterpy is not imported yet."""
    if 'filterpy.kalman' in sys.modules:
        imported: type = sys.modules['filterpy.kalman'].KalmanFilter
        return imported
    try:
        return _light_class()
    except Exception:  # noqa: B902 - any surprise in filterpy's layout: the normal import
        from filterpy.kalman import KalmanFilter
        normal: type = KalmanFilter
        return normal


#: filterpy's ``KalmanFilter``: the class of a full ``import filterpy.kalman`` if that came
#: first, else the same code loaded light. The one public name of this module.
KalmanFilter = _kalman_filter_class()
