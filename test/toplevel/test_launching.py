"""gear_phm.launching: the parameters files a launch file hands on, valid in any namespace."""
from __future__ import annotations

import os
from pathlib import Path

import pytest
import yaml

from gear_phm.launching import any_namespace, LaunchFileError, namespaced_copy
from gear_phm.transmissions import TransmissionsError

REPO = Path(__file__).resolve().parents[2]
CONFIG = REPO / 'config'


def test_node_keys_are_made_valid_in_any_namespace() -> None:
    document = {'estimator': {'ros__parameters': {'ratio': 30.0}},
                '/diagnostics': {'ros__parameters': {'rate': 2.0}},
                '/**': {'ros__parameters': {'use_sim_time': True}},
                '/**/publisher': {'ros__parameters': {'seed': 3}}}
    assert any_namespace(document) == {
        '/**/estimator': {'ros__parameters': {'ratio': 30.0}},
        '/**/diagnostics': {'ros__parameters': {'rate': 2.0}},
        '/**': {'ros__parameters': {'use_sim_time': True}},
        '/**/publisher': {'ros__parameters': {'seed': 3}}}


def test_a_cli_transmissions_file_becomes_the_bench_nodes_parameters() -> None:
    """config/bench.yaml (CLI form) gives what config/bench_nodes.yaml gives the nodes."""
    cli = any_namespace(yaml.safe_load((CONFIG / 'bench.yaml').read_text()))
    nodes = yaml.safe_load((CONFIG / 'bench_nodes.yaml').read_text())
    assert cli == nodes
    assert cli['/**']['ros__parameters']['transmissions'] == ['flap_l', 'spoiler_3', 'rudder']


@pytest.mark.parametrize(('document', 'reason'), [
    ([1, 2], 'expected a mapping of node names, got list'),
    ({'estimator': {'ratio': 3.0}}, "node 'estimator' holds no ros__parameters mapping"),
    ({'estimator': {'ros__parameters': {}}, '/estimator': {'ros__parameters': {}}},
     "node '/estimator' is given twice"),
])
def test_a_file_that_is_no_parameters_file_is_refused(document: object, reason: str) -> None:
    with pytest.raises(LaunchFileError, match=reason):
        any_namespace(document, 'f.yaml')


def test_a_missing_file_names_itself(tmp_path: Path) -> None:
    with pytest.raises(TransmissionsError, match='missing.yaml: cannot be read'):
        namespaced_copy(tmp_path / 'missing.yaml')


@pytest.mark.parametrize(('source', 'node', 'key', 'value'), [
    ('estimator.yaml', 'estimator', 'gate_threshold', 10.83),
    ('diagnostics.yaml', 'diagnostics', 'transmission_name', 'gearbox'),
    ('publisher.yaml', 'publisher', 'rate', 100.0),
    ('bench.yaml', 'estimator', 'flap_l.ratio', 30.0),
    ('bench_nodes.yaml', 'diagnostics', 'flap_l.eta_opposing_min', 0.6),
])
@pytest.mark.parametrize('namespace', ['', '/rig_a', '/hangar/bench_2'])
def test_rcl_gives_a_namespaced_node_the_copy_s_parameters(
        source: str, node: str, key: str, value: object, namespace: str) -> None:
    """Read the copy with rclpy as the node does: the files' values, in any namespace.

    The original config/<node>.yaml keys its node by name, which rcl applies to the node
    without namespace only.
    """
    rclpy = pytest.importorskip('rclpy')
    from rclpy.node import Node

    copy = namespaced_copy(CONFIG / source)
    try:
        overrides = {}
        originals = () if source == 'bench.yaml' else (str(CONFIG / source),)   # CLI form
        for params_file in (copy, *originals):
            args = ['--ros-args', '--params-file', params_file]
            if namespace:
                args += ['-r', f'__ns:={namespace}']
            context = rclpy.Context()
            rclpy.init(args=args, context=context)
            try:
                ros_node = Node(node, context=context, enable_rosout=False,
                                start_parameter_services=False)
                assert ros_node.get_namespace() == (namespace or '/')
                overrides[params_file] = {k: p.value for k, p in
                                          ros_node._parameter_overrides.items()}
                ros_node.destroy_node()
            finally:
                rclpy.shutdown(context=context)
        assert overrides[copy][key] == value
        if originals:
            # The original reaches the node without namespace only: what the copy is for.
            reaches = not namespace or source == 'bench_nodes.yaml'     # its key is /**
            assert (key in overrides[originals[0]]) == reaches
    finally:
        os.unlink(copy)
