"""rosbag2's metadata.yaml (gear_phm.bagio.metadata): QoS text, writing it, its file list."""
from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from gear_phm.bagio.metadata import (listed_files, METADATA_FILE, qos_list, TopicInfo,
                                     write_metadata)

PROFILE = {'history': 1, 'depth': 10, 'reliability': 1, 'durability': 2, 'deadline': {},
           'lifespan': {}, 'liveliness': 1, 'liveliness_lease_duration': {},
           'avoid_ros_namespace_conventions': False}


@pytest.mark.parametrize('text', ['', ': not yaml: [', '{a: 1}', '- {history: 1}'])
def test_qos_text_that_is_not_a_list_of_whole_profiles_is_no_profile(text: str) -> None:
    assert qos_list(text) == []


def test_qos_text_of_whole_profiles_is_read_as_they_are() -> None:
    assert qos_list(yaml.safe_dump([PROFILE, PROFILE])) == [PROFILE, PROFILE]


def test_written_metadata_counts_times_and_files(tmp_path: Path) -> None:
    (tmp_path / 'bag_0.mcap').write_bytes(b'')
    (tmp_path / 'bag_1.mcap').write_bytes(b'')
    topics = [TopicInfo('/joint_states', 'sensor_msgs/msg/JointState', 1, 'RIHS01_ab', 7,
                        [PROFILE]),
              TopicInfo('/empty', 'std_msgs/msg/String', 2, 'RIHS01_cd')]
    files = [('bag_0.mcap', 1_000, 5_000, 4), ('bag_1.mcap', 6_000, 9_500, 3),
             ('bag_2.mcap', 0, 0, 0)]            # an empty file: no time span of its own
    write_metadata(tmp_path, files[:2], topics, {'origin': 'test'})
    info = yaml.safe_load((tmp_path / METADATA_FILE).read_text())['rosbag2_bagfile_information']
    assert (info['version'], info['storage_identifier'], info['ros_distro']) == (9, 'mcap',
                                                                                 'jazzy')
    assert info['message_count'] == 7
    assert info['starting_time']['nanoseconds_since_epoch'] == 1_000
    assert info['duration']['nanoseconds'] == 8_500
    assert [f['duration']['nanoseconds'] for f in info['files']] == [4_000, 3_500]
    assert info['custom_data'] == {'origin': 'test'}
    assert info['topics_with_message_count'][0]['topic_metadata']['offered_qos_profiles'] \
        == [PROFILE]
    assert listed_files(tmp_path) == [tmp_path / 'bag_0.mcap', tmp_path / 'bag_1.mcap']
    write_metadata(tmp_path, files, topics)
    assert listed_files(tmp_path) is None                   # bag_2.mcap is not there


def test_no_or_unreadable_metadata_lists_no_file(tmp_path: Path) -> None:
    assert listed_files(tmp_path) is None
    (tmp_path / METADATA_FILE).write_text('rosbag2_bagfile_information: {}\n')
    assert listed_files(tmp_path) is None
    write_metadata(tmp_path, [], [])
    info = yaml.safe_load((tmp_path / METADATA_FILE).read_text())['rosbag2_bagfile_information']
    assert info['duration'] == {'nanoseconds': 0} and info['message_count'] == 0
    assert listed_files(tmp_path) is None                   # it lists no file
