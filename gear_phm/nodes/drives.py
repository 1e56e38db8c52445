"""The ``transmissions`` node parameter: many drives served by one node.

As ros2_control names its joints: ``transmissions`` (string array) lists the drives; each
name holds its own parameters ``<drive>.motor_joint``, ``<drive>.load_joint``,
``<drive>.ratio`` (required) and any of the node's estimator or health parameters
(``<drive>.eta_opposing_min``, ...), declared with descriptors and defaulting to the node's
global parameter of the same name. An empty list (the default) is the single transmission of
the node's global parameters, unchanged. The list is checked by
:func:`gear_phm.transmissions.from_parameters` (the one home of the drives list); a bad list
stops the node at start with the reason (:class:`~gear_phm.nodes.common.ConfigError`).
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import replace
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.parameter import Parameter

from gear_phm.nodes.common import ConfigError, declare_parameters, declare_required
from gear_phm.parameters import LOAD_JOINT, MOTOR_JOINT, ParamSpec, RATIO
from gear_phm.transmissions import (DRIVE_KEYS, from_parameters, NAME_PATTERN, SIMULATION,
                                    Transmission, TRANSMISSIONS, TransmissionsError)

#: The description of the ``transmissions`` parameter.
TRANSMISSIONS_TEXT = ('names of the drives this node serves (empty: one transmission, the '
                      'global motor_joint/load_joint/ratio); each name holds <name>.motor_joint, '
                      '<name>.load_joint, <name>.ratio and any estimator or health parameter '
                      '(default: the global one)')
_REQUIRED = (MOTOR_JOINT, LOAD_JOINT, RATIO)


def declare_transmissions(node: Node) -> list[str]:
    """Declare the ``transmissions`` string array (read at start only); return its names."""
    return declare_string_array(node, TRANSMISSIONS, TRANSMISSIONS_TEXT)


def declare_string_array(node: Node, name: str, description: str) -> list[str]:
    """Declare a read-only string array parameter, default empty; its value.

    rclpy types an empty default as a byte array, so the parameter is declared by type, set to
    an empty string array when not given, and then made read-only (its descriptor): a change
    after start is refused by rclpy with its reason.
    """
    descriptor = ParameterDescriptor(description=f'{description} (read at start only)')
    try:
        value = node.declare_parameter(name, Parameter.Type.STRING_ARRAY, descriptor).value
        if value is None:
            node.set_parameters([Parameter(name, Parameter.Type.STRING_ARRAY, [])])
        node.set_descriptor(name, ParameterDescriptor(
            description=descriptor.description, read_only=True,
            type=Parameter.Type.STRING_ARRAY.value))
    except ParameterException as exc:
        msg = f'parameter {name}: {" ".join(str(exc).split())}'
        raise ConfigError(msg) from None
    return list(value or [])


def declare_drives(node: Node, names: list[str], specs: Iterable[ParamSpec],
                   values: Mapping[str, Any]) -> tuple[Transmission, ...]:
    """Declare each drive's parameters and return the checked drives.

    ``specs``: the node's per-drive parameters (estimator or health ones); each is declared
    read-only as ``<drive>.<name>`` with the global value ``values[name]`` as default. The
    joints and the ratio have no default. Raises :class:`ConfigError` with the reason: a
    refused value, an unknown ``<drive>.<key>``, a ``<name>.<joint or ratio>`` of no listed
    drive, or any refusal of :func:`gear_phm.transmissions.from_parameters` (duplicate joint,
    missing joint or ratio, bad name, ...).
    """
    _check_overrides(node, names)
    required = {spec.name for spec in _REQUIRED}
    specs = [spec for spec in specs if spec.name in DRIVE_KEYS and spec.name not in required]
    parameters: dict[str, Any] = {}
    for drive in dict.fromkeys(names):          # a bad or repeated name: from_parameters
        if not NAME_PATTERN.match(drive):      # gives the reason
            continue
        parameters.update(declare_required(node, (
            replace(spec, name=f'{drive}.{spec.name}', read_only=True,
                    description=f'{drive}: {spec.description}') for spec in _REQUIRED)))
        parameters.update(declare_parameters(node, (
            replace(spec, name=f'{drive}.{spec.name}', default=values[spec.name],
                    read_only=True, description=f'{drive}: {spec.description}')
            for spec in specs)))
    try:
        return from_parameters(names, parameters)
    except TransmissionsError as exc:
        raise ConfigError(f'parameter {TRANSMISSIONS}: {exc}') from None


def _check_overrides(node: Node, names: list[str]) -> None:
    """Refuse a ``<drive>.<key>`` override that no drive holds (a typo would be ignored).

    rclpy keeps the overrides (parameters file, ``-p``) of undeclared names only in
    ``Node._parameter_overrides``; there is no public accessor.
    """
    overrides: Mapping[str, Any] = getattr(node, '_parameter_overrides', {})
    drives = set(names)
    for key in sorted(overrides):
        drive, dot, rest = key.partition('.')
        if not dot:
            continue
        if drive in drives and rest not in DRIVE_KEYS \
                and not rest.startswith(SIMULATION + '.'):
            msg = (f'parameter {key}: unknown key {rest!r} of drive {drive}; a drive holds '
                   f'motor_joint, load_joint, ratio and estimator or health parameters')
            raise ConfigError(msg)
        if drive not in drives and rest in (MOTOR_JOINT.name, LOAD_JOINT.name, RATIO.name):
            msg = f'parameter {key} names no drive of {TRANSMISSIONS} {names}'
            raise ConfigError(msg)


#: The parameters a node serving many drives takes at run time: rclpy's clock switch and the
#: estimator's frame_id (a label); the others are read at start only.
LIVE_WITH_DRIVES = ('use_sim_time', 'frame_id')


def refuse_changes(params: Sequence[Any]) -> SetParametersResult:
    """On-set callback of a node serving many drives: refuse all but :data:`LIVE_WITH_DRIVES`."""
    refused = [p.name for p in params if p.name not in LIVE_WITH_DRIVES]
    if not refused:
        return SetParametersResult(successful=True)
    return SetParametersResult(successful=False, reason=f'{", ".join(refused)}: with '
                               f'{TRANSMISSIONS} the parameters are read at start only; '
                               f'restart the node')
