"""LoadTorqueMatcher: the wrench of the nearest stamp within the tolerance, decided once."""
from __future__ import annotations

import pytest

from gear_phm.estimation.load_torque import LoadTorqueMatcher

ROW = (1.0, 2.0, 3.0, float('nan'))     # the JointState's own load effort is ignored


def test_exact_stamps_match_at_once() -> None:
    matcher = LoadTorqueMatcher(0, 10**9)
    for stamp, torque in ((100, 5.0), (200, 6.0)):
        matcher.add(stamp, torque)
    out = matcher.match([100, 200, 150], [ROW] * 3)
    assert out.stamps == [100, 200] and [r[3] for r in out.rows] == [5.0, 6.0]
    assert out.rows[0][:3] == ROW[:3]
    assert out.dropped == 1 and not out.pending_stamps      # 150: no wrench at its stamp


def test_nearest_within_the_tolerance_waits_for_a_nearer_one() -> None:
    matcher = LoadTorqueMatcher(30, 10**9)
    matcher.add(95, 1.0)
    out = matcher.match([100, 200], [ROW] * 2)
    # 100: a wrench at up to 130 could still come; 200: none yet
    assert out.stamps == [] and out.pending_stamps == [100, 200] and out.dropped == 0
    matcher.add(104, 2.0)
    matcher.add(260, 3.0)
    out = matcher.match(out.pending_stamps, out.pending_rows)
    assert out.stamps == [100] and out.rows[0][3] == 2.0    # 104 is nearer than 95
    assert out.dropped == 1                                 # 200: 260 is 60 away


def test_an_old_undecided_sample_is_decided_and_final_decides_all() -> None:
    matcher = LoadTorqueMatcher(30, 1000)
    matcher.add(90, 1.0)
    out = matcher.match([100, 2000], [ROW] * 2)
    assert out.stamps == [100] and out.pending_stamps == [2000]
    out = matcher.match(out.pending_stamps, out.pending_rows, final=True)
    assert out.stamps == [] and out.dropped == 1


def test_a_late_wrench_goes_in_stamp_order() -> None:
    matcher = LoadTorqueMatcher(0, 10**9)
    for stamp in (100, 300, 200):
        matcher.add(stamp, stamp * 0.01)
    out = matcher.match([100, 200, 300], [ROW] * 3)
    assert [r[3] for r in out.rows] == pytest.approx([1.0, 2.0, 3.0])


def test_refuses_a_negative_tolerance() -> None:
    with pytest.raises(ValueError, match='>= 0'):
        LoadTorqueMatcher(-1, 0)
