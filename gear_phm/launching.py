"""Parameter files for the launch files (launch/*.launch.py): any namespace, either form.

A ROS 2 parameters file names its nodes: ``estimator:`` applies to the node ``/estimator``
only, not to ``/bench_a/estimator``, and launch_ros passes a file to the node as it is. So a
launch file that takes a namespace hands each node a copy in which every node key holds
``/**/`` (any namespace): ``estimator`` and ``/estimator`` become ``/**/estimator``; keys
that already start with ``/**`` are kept. A transmissions file of the CLI
(``transmissions: {drive: {...}}``, config/bench.yaml) becomes the node parameters of
config/bench_nodes.yaml, for every node (``/**``). No ROS here: the files are YAML.
"""
from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
import tempfile
from typing import Any

import yaml

from gear_phm.errors import GearPhmError
from gear_phm.transmissions import read_yaml, ROS_PARAMETERS, TRANSMISSIONS

#: The node key of a parameters file that matches every node in every namespace.
EVERY_NODE = '/**'


class LaunchFileError(GearPhmError, ValueError):
    """A parameters file a launch file cannot pass on, with the reason."""


def any_namespace(document: Any, where: str = 'parameters file') -> dict[str, Any]:
    """Return the parameters ``document`` with each node key valid in any namespace.

    A CLI transmissions document (``transmissions`` a mapping of drives) becomes node
    parameters for every node: ``transmissions`` the list of drive names, each drive's keys
    under its name. Raises :class:`LaunchFileError` when ``document`` is neither a mapping of
    node names to ``ros__parameters`` mappings nor a transmissions document.
    """
    if not isinstance(document, Mapping):
        msg = f'{where}: expected a mapping of node names, got {type(document).__name__}'
        raise LaunchFileError(msg)
    drives = document.get(TRANSMISSIONS)
    if isinstance(drives, Mapping):
        return {EVERY_NODE: {ROS_PARAMETERS: {TRANSMISSIONS: [str(n) for n in drives],
                                              **{str(n): v for n, v in drives.items()}}}}
    rewritten: dict[str, Any] = {}
    for key, entry in document.items():
        if not isinstance(entry, Mapping) or ROS_PARAMETERS not in entry:
            msg = f'{where}: node {key!r} holds no {ROS_PARAMETERS} mapping'
            raise LaunchFileError(msg)
        name = str(key)
        if not name.startswith(EVERY_NODE):
            name = f'{EVERY_NODE}/{name.lstrip("/")}'
        if name in rewritten:
            msg = f'{where}: node {key!r} is given twice'
            raise LaunchFileError(msg)
        rewritten[name] = dict(entry)
    return rewritten


def namespaced_copy(path: str | Path) -> str:
    """Write :func:`any_namespace` of the YAML file ``path`` to a temporary file; its path.

    The copy is left for the node to read at start (as launch_ros does with the parameter
    dictionaries of a launch file). Raises :class:`LaunchFileError` (the file's problem) and
    :class:`gear_phm.transmissions.TransmissionsError` (a file that cannot be read).
    """
    document = any_namespace(read_yaml(path), str(path))
    with tempfile.NamedTemporaryFile('w', prefix='gear_phm_params_', suffix='.yaml',
                                     delete=False, encoding='utf-8') as handle:
        yaml.safe_dump(document, handle, sort_keys=False)
    return handle.name
