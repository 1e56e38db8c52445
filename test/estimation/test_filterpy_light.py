"""The light load of filterpy's KalmanFilter is filterpy's own filter, minus the import cost.

Each check runs in a fresh interpreter, through the package's own import path
(``gear_phm.estimation.kalman``), so what is imported first is under the test's control.
"""
from __future__ import annotations

import subprocess
import sys

_IMPORTS = """
import sys
import gear_phm.offline.engine  # the analyze path: estimator and prognostics
heavy = sorted(m for m in ('filterpy', 'filterpy.stats', 'scipy', 'scipy.stats', 'matplotlib')
               if m in sys.modules)
print(','.join(heavy))
from gear_phm.estimation.kalman import KalmanFilter
import filterpy.kalman  # a later full import by anyone else still works
print(KalmanFilter is not filterpy.kalman.KalmanFilter, 'scipy.stats' in sys.modules)
"""

_STEPS = """
import numpy as np
from gear_phm.estimation.kalman import KalmanFilter as Light   # loaded light: filterpy not yet
from filterpy.kalman import KalmanFilter as Full
from gear_phm.estimation import filterpy_light
assert Light is filterpy_light.KalmanFilter       # the class the light load made
assert Light is not Full and Light.__name__ == 'KalmanFilter'
rng = np.random.default_rng(7)
filters = [cls(dim_x=2, dim_z=1) for cls in (Light, Full)]
for kf in filters:
    kf.x = np.array([[0.05], [0.0]])
    kf.P = np.diag([0.25, 1e-6])
    kf.H = np.array([[1.0, 0.0]])
for _ in range(200):
    dt = float(rng.uniform(0.1, 2.0))
    f = np.array([[1.0, dt], [0.0, 1.0]])
    q = 1e-9 * np.array([[dt ** 3 / 3, dt ** 2 / 2], [dt ** 2 / 2, dt]])
    z, r = float(rng.normal(0.05, 0.01)), float(rng.uniform(1e-5, 1e-4))
    for kf in filters:
        kf.predict(F=f, Q=q)
        kf.update(np.array([[z]]), R=np.array([[r]]))
light, full = filters
np.testing.assert_allclose(light.x, full.x, rtol=1e-12, atol=0)
np.testing.assert_allclose(light.P, full.P, rtol=1e-12, atol=0)
np.testing.assert_allclose(light.log_likelihood, full.log_likelihood, rtol=1e-12)
print('equal')
"""

_FULL_FIRST = """
import filterpy.kalman
from gear_phm.estimation.kalman import KalmanFilter
print(KalmanFilter is filterpy.kalman.KalmanFilter)
"""


def _run(source: str) -> list[str]:
    return subprocess.run([sys.executable, '-c', source], check=True, capture_output=True,
                          text=True, timeout=120).stdout.splitlines()


def test_the_analyze_path_imports_neither_scipy_nor_matplotlib() -> None:
    assert _run(_IMPORTS) == ['', 'True True']


def test_light_filter_equals_filterpy_kalman_filter_step_for_step() -> None:
    assert _run(_STEPS) == ['equal']


def test_after_a_full_filterpy_import_the_package_uses_filterpys_class() -> None:
    assert _run(_FULL_FIRST) == ['True']
