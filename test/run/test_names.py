"""One drive's names: the single transmission keeps today's names, a listed drive its own."""
from __future__ import annotations

import pickle

from gear_phm.interfaces import HEALTH_RUL, SAMPLE_LOSS
from gear_phm.run import DriveNames, ESTIMATOR_STATUS_NAME


def test_the_single_transmission_keeps_the_node_names() -> None:
    names = DriveNames.single('left_flap', 'hw7')
    assert (names.drive, names.transmission_name, names.hardware_id) == ('', 'left_flap', 'hw7')
    assert names.estimator_status == ESTIMATOR_STATUS_NAME
    assert names.topic(HEALTH_RUL) == HEALTH_RUL
    assert names.plot_file == 'analysis.png' and names.file_suffix == ''
    assert (names.label, names.aside, names.ratio_where) == ('', '', '--ratio')
    assert names.param_where.format('load_effort_sign', -1) == '--param load_effort_sign=-1'
    assert not names.listed
    assert DriveNames.chosen(None) == DriveNames.single()


def test_a_listed_drive_names_its_topics_statuses_and_files() -> None:
    names = DriveNames.of('rudder')
    assert (names.drive, names.transmission_name, names.hardware_id) == ('rudder',) * 3
    assert names.estimator_status == 'gear_phm estimator: rudder'
    assert names.topic(HEALTH_RUL) == 'gear_phm/rudder/health/rul'
    assert names.topic(SAMPLE_LOSS) == 'gear_phm/rudder/sample_loss'
    assert names.plot_file == 'analysis_rudder.png'
    assert names.label == 'drive rudder: ' and names.aside == ' (drive rudder)'
    assert names.ratio_where == 'the ratio in the entry of drive rudder'
    assert names.param_where.format('motor_effort_sign', -1) == \
        'motor_effort_sign: -1 in the entry of drive rudder'
    assert names.listed
    assert DriveNames.chosen('rudder') == names


def test_names_travel_to_worker_processes() -> None:
    """The drive workers get their runs by fork, their health halves by pickle."""
    for names in (DriveNames.single(), DriveNames.of('flap_l')):
        copy = pickle.loads(pickle.dumps(names))
        assert copy.topic(HEALTH_RUL) == names.topic(HEALTH_RUL)
        assert copy.plot_file == names.plot_file
