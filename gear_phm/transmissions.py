"""Many transmissions (drives) in one JointState stream: the one home of their list (no ROS).

A bench or an aircraft publishes the joints of all its geared drives in one ``joint_states``
message. A transmissions list names the drives; each drive has its two joints, its ratio and,
optionally, its own estimator, health and simulation parameters. Two forms are read:

- the CLI file (``gear-phm analyze/simulate --transmissions FILE``, a fleet unit's
  ``unit.yaml``)::

      transmissions:
        flap_l:    {motor_joint: pdu_l, load_joint: flap_l_out, ratio: 30.0,
                    eta_opposing_min: 0.86, simulation: {wear: linear, wear_rate: 1e-4}}
        spoiler_3: {motor_joint: spl3_motor, load_joint: spl3_out, ratio: 12.0}

- a node parameters file, as ros2_control names its joints (several node entries are merged;
  keys of ``ros__parameters`` that are estimator or health parameters apply to every drive)::

      estimator:
        ros__parameters:
          transmissions: [flap_l, spoiler_3]
          flap_l.motor_joint: pdu_l        # or nested: flap_l: {motor_joint: pdu_l, ...}

A drive's keys: ``motor_joint``, ``load_joint``, ``ratio`` (required), any estimator
(:data:`gear_phm.estimation.config.PARAMETERS`) or health
(:data:`gear_phm.prognostics.config.PARAMETERS`) parameter by name, and ``simulation``, a
mapping of simulation parameters (:data:`gear_phm.simulation.parameters.PARAMETERS`, but the
ratio, which is the drive's). Global options apply to each drive that does not set its own.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
import functools
from pathlib import Path
import re
from typing import Any

from gear_phm.errors import GearPhmError
from gear_phm.estimation.config import EstimatorConfig
from gear_phm.estimation.config import PARAMETERS as ESTIMATOR_PARAMETERS
from gear_phm.parameters import LOAD_JOINT, MOTOR_JOINT, RATIO, spec_map, Value
from gear_phm.prognostics.config import HealthConfig, NOT_OFFLINE_OPTIONS
from gear_phm.prognostics.config import PARAMETERS as HEALTH_PARAMETERS

#: The key (file) and the node parameter (string array) that list the drives.
TRANSMISSIONS = 'transmissions'
#: A drive's key holding its simulation parameters.
SIMULATION = 'simulation'
#: The key of a node's parameters in a ROS 2 parameters file.
ROS_PARAMETERS = 'ros__parameters'
#: A drive name: a ROS parameter and topic name segment.
NAME_PATTERN = re.compile(r'^[A-Za-z][A-Za-z0-9_]*$')

_JOINTS = (MOTOR_JOINT.name, LOAD_JOINT.name)
_ESTIMATOR = spec_map(s for s in ESTIMATOR_PARAMETERS if s.name != RATIO.name)
_HEALTH = spec_map(s for s in HEALTH_PARAMETERS if s.name != RATIO.name)
#: The keys a drive may hold.
DRIVE_KEYS = frozenset((*_JOINTS, RATIO.name, *_ESTIMATOR, *_HEALTH, SIMULATION))
#: What each drive of a transmissions list sets for itself: not given beside the list.
DRIVE_OWN = (RATIO.name, *_JOINTS, 'transmission_name', 'hardware_id')


def drive_own_given(given: Sequence[str]) -> str:
    """Return the refusal of :data:`DRIVE_OWN` options ``given`` beside a list ('' if none)."""
    if not given:
        return ''
    return (f'with transmissions, each drive sets its own ratio, joints and names: drop '
            f'{", ".join(given)}')


class TransmissionsError(GearPhmError, ValueError):
    """A transmissions list that cannot be used, with the reason: one line."""


@dataclass(frozen=True)
class Transmission:
    """One drive: its name, joints, ratio R [-] and its own parameter values.

    ``estimator``/``health``: parameter values by name (the ratio excluded), global options
    merged in; ``simulation``: simulation parameter values by name (the ratio excluded).
    """

    name: str
    motor_joint: str
    load_joint: str
    ratio: float
    estimator: Mapping[str, Any] = field(default_factory=dict)
    health: Mapping[str, Any] = field(default_factory=dict)
    simulation: Mapping[str, Value] = field(default_factory=dict)

    def estimator_config(self) -> EstimatorConfig:
        """Return the drive's validated estimator parameters (ValueError if inconsistent)."""
        return EstimatorConfig(ratio=self.ratio, **self.estimator)

    def health_config(self) -> HealthConfig:
        """Return the drive's validated health parameters (ValueError if inconsistent)."""
        return HealthConfig(ratio=self.ratio, **self.health)

    def simulation_values(self, shared: Mapping[str, Value], index: int) -> dict[str, Value]:
        """Return this drive's simulation parameter values, its ratio included.

        ``shared``: the global simulation values (with ``seed``); the drive's own keys
        override them and its seed is ``shared['seed'] + index`` (``index``: its place in the
        list), as ``gear-phm simulate --transmissions`` and the publisher node simulate it.
        """
        seed = shared.get('seed', 0)
        assert isinstance(seed, int)
        return {**shared, 'seed': seed + index, **self.simulation, RATIO.name: self.ratio}

    def offline_options(self) -> dict[str, Value]:
        """Return the estimator and health values the offline tools take.

        These are ``analyze_bag``'s options: the live-only
        :data:`~gear_phm.prognostics.config.NOT_OFFLINE_OPTIONS` are left out.
        """
        return {**self.estimator, **{k: v for k, v in self.health.items()
                                     if k not in NOT_OFFLINE_OPTIONS}}


def _fail(msg: str) -> TransmissionsError:
    return TransmissionsError(msg)


def parse_transmissions(document: Any, defaults: Mapping[str, Any] | None = None
                        ) -> tuple[Transmission, ...]:
    """Return the drives of a transmissions document (either form, module docstring).

    ``defaults``: global estimator/health values applied to drives that do not set their own.
    Raises :class:`TransmissionsError` on: no list, an empty list, a bad drive name, an
    unknown key in a drive, a missing joint or ratio, a bad value (ratio included), a joint
    used twice (by two drives or both ends of one).
    """
    if not isinstance(document, Mapping):
        raise _fail(f'expected a mapping with a {TRANSMISSIONS!r} key, got {document!r:.60}')
    if TRANSMISSIONS in document:
        entries = document[TRANSMISSIONS]
        extra = sorted(set(document) - {TRANSMISSIONS})
        if extra:
            raise _fail(f'unknown top-level key(s) {extra}; expected only {TRANSMISSIONS!r}')
        if isinstance(entries, Sequence) and not isinstance(entries, str):
            raise _fail(f'{TRANSMISSIONS} must map each drive name to its keys (a list of '
                        f'names belongs in a node parameters file, under {ROS_PARAMETERS})')
        if not isinstance(entries, Mapping):
            raise _fail(f'{TRANSMISSIONS} must map each drive name to its keys, got '
                        f'{entries!r:.60}')
        return _drives(entries, dict(defaults or {}))
    nodes = [v[ROS_PARAMETERS] for v in document.values()
             if isinstance(v, Mapping) and ROS_PARAMETERS in v]
    if not nodes:
        raise _fail(f'no {TRANSMISSIONS!r} key and no node {ROS_PARAMETERS}')
    merged: dict[str, Any] = {}
    for parameters in nodes:
        if not isinstance(parameters, Mapping):
            raise _fail(f'{ROS_PARAMETERS} must be a mapping, got {parameters!r:.60}')
        for key, value in _flatten(parameters).items():
            if key in merged and merged[key] != value:
                raise _fail(f'parameter {key} is {merged[key]!r} in one node and {value!r} '
                            f'in another')
            merged[key] = value
    if TRANSMISSIONS not in merged:
        raise _fail(f'no node sets the parameter {TRANSMISSIONS!r}')
    return from_parameters(merged.pop(TRANSMISSIONS), merged, defaults)


def from_parameters(names: Any, parameters: Mapping[str, Any],
                    defaults: Mapping[str, Any] | None = None) -> tuple[Transmission, ...]:
    """Return the drives named by ``names`` from flat node parameters ``<drive>.<key>``.

    Parameters without a dot that are estimator or health parameters are global values (the
    node's own), which ``defaults`` do not override; other undotted ones (a node's ``rate``,
    ``state_file``, ...) are not the drives' business. A dotted key must name a listed drive.
    Raises :class:`TransmissionsError` as :func:`parse_transmissions`.
    """
    if isinstance(names, str) or not isinstance(names, Sequence):
        raise _fail(f'{TRANSMISSIONS} must be a list of drive names, got {names!r:.60}')
    if not all(isinstance(name, str) for name in names):
        raise _fail(f'{TRANSMISSIONS} must be a list of drive names, got {list(names)!r:.60}')
    glob = dict(defaults or {})
    drives: dict[str, dict[str, Any]] = {name: {} for name in names}
    if len(drives) != len(names):
        raise _fail(f'{TRANSMISSIONS} names a drive twice: {list(names)}')
    for key, value in parameters.items():
        drive, dot, rest = key.partition('.')
        if not dot:
            if key in _ESTIMATOR or key in _HEALTH:
                glob[key] = value
            continue
        if drive not in drives:
            raise _fail(f'parameter {key} names no drive of {TRANSMISSIONS} {list(names)}')
        if rest.startswith(SIMULATION + '.'):
            drives[drive].setdefault(SIMULATION, {})[rest[len(SIMULATION) + 1:]] = value
        else:
            drives[drive][rest] = value
    return _drives(drives, glob)


def _flatten(parameters: Mapping[str, Any], prefix: str = '') -> dict[str, Any]:
    """ROS parameters file nesting -> dotted names (``a: {b: 1}`` is ``a.b: 1``)."""
    flat: dict[str, Any] = {}
    for key, value in parameters.items():
        name = f'{prefix}{key}'
        if isinstance(value, Mapping):
            flat.update(_flatten(value, name + '.'))
        else:
            flat[name] = value
    return flat


def _drives(entries: Mapping[str, Any], defaults: dict[str, Any]) -> tuple[Transmission, ...]:
    if not entries:
        raise _fail(f'{TRANSMISSIONS} is empty: name at least one drive')
    unknown = sorted(set(defaults) - set(_ESTIMATOR) - set(_HEALTH))
    if unknown:
        raise _fail(f'unknown global option(s) {unknown}')
    drives = tuple(_drive(name, keys, defaults) for name, keys in entries.items())
    users: dict[str, str] = {}
    for drive in drives:
        for joint in (drive.motor_joint, drive.load_joint):
            if joint in users:
                other = users[joint]
                where = (f'both ends of {drive.name}' if other == drive.name
                         else f'{other} and {drive.name}')
                raise _fail(f'joint {joint!r} is used by {where}: each joint belongs to one '
                            f'drive')
            users[joint] = drive.name
    return drives


def _drive(name: Any, keys: Any, defaults: Mapping[str, Any]) -> Transmission:
    if not isinstance(name, str) or not NAME_PATTERN.match(name):
        raise _fail(f'drive name {name!r} must be a letter then letters, digits or _ (it '
                    f'becomes a parameter prefix and a topic segment)')
    if keys is None:
        keys = {}
    if not isinstance(keys, Mapping):
        raise _fail(f'drive {name}: expected a mapping of its keys, got {keys!r:.60}')
    unknown = sorted(set(keys) - DRIVE_KEYS)
    if unknown:
        raise _fail(f'drive {name}: unknown key(s) {unknown}; a drive holds motor_joint, '
                    f'load_joint, ratio, {SIMULATION} and estimator or health parameters')
    for required in (*_JOINTS, RATIO.name):
        if required not in keys:
            raise _fail(f'drive {name}: missing {required}')
    joints = []
    for joint in _JOINTS:
        value = keys[joint]
        if not isinstance(value, str) or not value:
            raise _fail(f'drive {name}: {joint} must be a non-empty joint name, got {value!r}')
        joints.append(value)
    try:
        ratio = float(RATIO.check(keys[RATIO.name]))
        estimator = {k: _ESTIMATOR[k].check(v) for k, v in {**defaults, **keys}.items()
                     if k in _ESTIMATOR}
        health = {k: _HEALTH[k].check(v) for k, v in {**defaults, **keys}.items()
                  if k in _HEALTH}
        simulation = _simulation(keys.get(SIMULATION))
        drive = Transmission(name, joints[0], joints[1], ratio, estimator, health, simulation)
        drive.estimator_config()
        drive.health_config()
    except ValueError as exc:
        raise _fail(f'drive {name}: {exc}') from None
    return drive


def _simulation(values: Any) -> dict[str, Value]:
    """Check a drive's simulation mapping (ValueError naming the bad key)."""
    if values is None:
        return {}
    if not isinstance(values, Mapping):
        raise ValueError(f'{SIMULATION} must be a mapping of simulation parameters, got '
                         f'{values!r:.60}')
    from gear_phm.simulation.parameters import PARAMETERS as SIMULATION_PARAMETERS
    table = spec_map(s for s in SIMULATION_PARAMETERS if s.name != RATIO.name)
    unknown = sorted(set(values) - set(table))
    if unknown:
        raise ValueError(f'{SIMULATION}: unknown key(s) {unknown}')
    return {k: table[k].check(v) for k, v in values.items()}


#: A YAML 1.2 float that PyYAML's YAML 1.1 resolver reads as a string: an exponent with no dot
#: or no sign, e.g. 1e-3, 1.5e3 (the others keep PyYAML's resolution).
_EXPONENT_FLOAT = r'^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$'


@functools.cache
def _loader() -> type:
    """Return a SafeLoader that refuses a key given twice and reads ``1e-3`` as a float.

    PyYAML keeps the last of duplicate keys (a drive silently replaced) and resolves
    ``1e-3``, which has no dot, as a string.
    """
    import yaml

    class Loader(yaml.SafeLoader):
        """SafeLoader with unique mapping keys and YAML 1.2 floats without a dot."""

        def construct_mapping(self, node: Any, deep: bool = False) -> dict[Any, Any]:
            seen: set[Any] = set()
            for key_node, _ in node.value:
                if key_node.tag == 'tag:yaml.org,2002:merge':
                    continue                    # merged keys (<<) may be overridden
                key = self.construct_object(key_node, deep=True)
                if isinstance(key, Mapping | list):
                    continue                    # unhashable: construct_mapping refuses it
                if key in seen:
                    line = key_node.start_mark.line + 1
                    msg = (f'line {line}: {key!r} is given twice in one mapping (a drive or a '
                           f'key named twice)')
                    raise TransmissionsError(msg) from None
                seen.add(key)
            mapping: dict[Any, Any] = super().construct_mapping(node, deep=deep)
            return mapping

    Loader.add_implicit_resolver('tag:yaml.org,2002:float', re.compile(_EXPONENT_FLOAT),
                                 list('-+.0123456789'))
    return Loader


def read_yaml(path: str | Path) -> Any:
    """Return the YAML document of the file ``path``, read with :func:`_loader`'s rules.

    A key given twice in a mapping is refused, and ``1e-3`` is a float. Raises
    :class:`TransmissionsError` (a ValueError) naming the file: unreadable, not UTF-8 text,
    not valid YAML, or a key given twice.
    """
    import yaml
    try:
        return yaml.load(Path(path).read_bytes().decode('utf-8'), _loader())  # noqa: S506
    except UnicodeDecodeError:
        msg = f'{path}: not UTF-8 text'
    except OSError as exc:
        msg = f'{path}: cannot be read ({exc.strerror or exc})'
    except yaml.YAMLError as exc:
        msg = f'{path}: not valid YAML ({" ".join(str(exc).split())})'
    except TransmissionsError as exc:
        msg = f'{path}: {exc}'
    raise TransmissionsError(msg)


def load_transmissions(path: str | Path, defaults: Mapping[str, Any] | None = None
                       ) -> tuple[Transmission, ...]:
    """Read a transmissions file (either form); see :func:`parse_transmissions`.

    Raises :class:`TransmissionsError` naming the file on a missing or unreadable file, bad
    YAML (:func:`read_yaml`) or a bad list.
    """
    document = read_yaml(path)
    try:
        return parse_transmissions(document, defaults)
    except TransmissionsError as exc:
        msg = f'{path}: {exc}'
        raise TransmissionsError(msg) from None
