"""The nodes' state parameters and the state of many drives (gear_phm.nodes.state)."""
from __future__ import annotations

from gear_phm.nodes.state import drives_state, estimator_identity, state_parameters


def test_the_three_state_parameters_name_what_is_kept() -> None:
    specs = state_parameters('the wear state')
    assert [(s.name, s.default, s.read_only) for s in specs] == [
        ('state_file', '', True), ('state_save_period', 10.0, True),
        ('state_reset', False, True)]
    assert 'the wear state across restarts' in specs[0].description
    assert (specs[1].low, specs[1].high, specs[1].unit) == (0.01, 86400.0, 's')


def test_an_estimator_s_identity_is_its_ratio_and_joints() -> None:
    identity = estimator_identity(3, 'motor', 'load')
    assert identity == {'ratio': 3.0, 'motor_joint': 'motor', 'load_joint': 'load'}
    assert isinstance(identity['ratio'], float)


def test_the_state_of_many_drives_holds_each_and_the_newest_stamp() -> None:
    left, right = estimator_identity(3.0, 'm1', 'l1'), estimator_identity(50.0, 'm2', 'l2')
    state, newest = drives_state({'left': (left, {'u': 0.1}, 5_000),
                                  'right': (right, {'u': 0.2}, 7_000),
                                  'idle': (left, {}, None)})
    assert newest == 7_000
    assert state == {'drives': {'left': {'identity': left, 'state': {'u': 0.1}},
                                'right': {'identity': right, 'state': {'u': 0.2}},
                                'idle': {'identity': left, 'state': {}}}}
    assert state['drives']['left']['identity'] is not left        # a copy
    assert drives_state({'idle': (left, {}, None)})[1] is None
