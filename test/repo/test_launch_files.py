"""launch/*.launch.py: what they start, with which executables, parameters and files.

ROS 2's ``launch`` and ``launch_ros`` are not on PyPI, so this environment has neither. The
launch files then run here against stand-ins of the few classes they use, written with the
signatures of the Jazzy sources (ros2/launch 3.4.3, ros2/launch_ros 0.26.6): a name the stand-ins
lack, or a keyword the real class lacks, fails as it would under ``ros2 launch``. The
stand-ins evaluate the substitutions and the conditions as launch does, so the test sees the
nodes that ``ros2 launch`` would start: each executable must be one that ``ros2 run gear_phm
<exe>`` finds, each parameter one that node declares, each file one that exists. Where the
real ``launch`` is importable, the last test loads the files with it.
"""
from __future__ import annotations

import ast
from collections.abc import Callable, Iterator
import configparser
import json
import os
from pathlib import Path
import re
import subprocess
import sys
import tempfile
import types
from typing import Any

import pytest
import yaml

from gear_phm.transmissions import _flatten

REPO = Path(__file__).resolve().parents[2]
LAUNCH = REPO / 'launch'
MAIN = LAUNCH / 'gear_phm.launch.py'
BENCH = LAUNCH / 'bench.launch.py'
PACKAGE = 'gear_phm'
#: Declared by rclpy for every node.
RCLPY_BUILTIN = {'use_sim_time', 'start_type_description_service'}

# --- stand-ins of launch and launch_ros (Jazzy signatures) ---------------------------------

#: Keywords of launch.Action and of launch.actions.ExecuteProcess (Jazzy).
ACTION_KWARGS = {'condition'}
EXECUTE_PROCESS_KWARGS = ACTION_KWARGS | {
    'name', 'cwd', 'env', 'additional_env', 'shell', 'sigterm_timeout', 'sigkill_timeout',
    'emulate_tty', 'output', 'output_format', 'cached_output', 'log_cmd', 'on_exit',
    'respawn', 'respawn_delay', 'respawn_max_retries', 'prefix'}


def _check_kwargs(cls: str, kwargs: dict[str, Any], allowed: set[str]) -> None:
    unknown = set(kwargs) - allowed
    if unknown:
        raise TypeError(f'{cls}() got unexpected keyword arguments {sorted(unknown)}')


class Context(dict):
    """The launch configurations (argument values) of a launch, by name."""


def perform(value: Any, context: Context) -> str:
    """Evaluate a substitution, a string or a list of them, as launch does."""
    if isinstance(value, str):
        return value
    if isinstance(value, (list, tuple)):
        return ''.join(perform(v, context) for v in value)
    return value.perform(context)


class LaunchConfiguration:
    def __init__(self, variable_name: Any, *, default: Any = None) -> None:
        self.variable_name, self.default = variable_name, default

    def perform(self, context: Context) -> str:
        name = perform(self.variable_name, context)
        if name in context:
            return context[name]
        if self.default is None:
            raise LookupError(f"launch configuration '{name}' does not exist")
        return perform(self.default, context)


class PathJoinSubstitution:
    def __init__(self, substitutions: Any) -> None:
        self.substitutions = list(substitutions)

    def perform(self, context: Context) -> str:
        return os.path.join(*(perform(s, context) for s in self.substitutions))


class FindPackageShare:
    """The package's share directory: the source tree, whose layout setup.py installs."""

    def __init__(self, package: Any) -> None:
        self.package = package

    def perform(self, context: Context) -> str:
        assert perform(self.package, context) == PACKAGE
        return str(REPO)


class IfCondition:
    def __init__(self, predicate_expression: Any) -> None:
        self.expression = predicate_expression

    def evaluate(self, context: Context) -> bool:
        value = perform(self.expression, context).strip().lower()
        if value not in ('true', 'false', '1', '0'):
            raise ValueError(f'IfCondition: {value!r} is not a boolean')
        return value in ('true', '1')


class LaunchDescription:
    def __init__(self, initial_entities: Any = None, *, deprecated_reason: Any = None) -> None:
        self.entities = list(initial_entities or [])


class DeclareLaunchArgument:
    def __init__(self, name: str, *, default_value: Any = None, description: Any = None,
                 choices: Any = None, **kwargs: Any) -> None:
        _check_kwargs('DeclareLaunchArgument', kwargs, ACTION_KWARGS)
        self.name, self.default_value = name, default_value
        self.description, self.choices = description, choices


class OpaqueFunction:
    def __init__(self, *, function: Callable, args: Any = None, kwargs: Any = None,
                 **left_over_kwargs: Any) -> None:
        _check_kwargs('OpaqueFunction', left_over_kwargs, ACTION_KWARGS)
        self.function, self.args, self.kwargs = function, args or [], kwargs or {}


class PythonLaunchDescriptionSource:
    def __init__(self, launch_file_path: Any) -> None:
        self.launch_file_path = launch_file_path


class IncludeLaunchDescription:
    def __init__(self, launch_description_source: Any, *, launch_arguments: Any = None,
                 **kwargs: Any) -> None:
        _check_kwargs('IncludeLaunchDescription', kwargs, ACTION_KWARGS)
        self.source = launch_description_source
        self.launch_arguments = list(launch_arguments or [])


class Node:
    def __init__(self, *, executable: Any, package: Any = None, name: Any = None,
                 namespace: Any = None, exec_name: Any = None, parameters: Any = None,
                 remappings: Any = None, ros_arguments: Any = None, arguments: Any = None,
                 **kwargs: Any) -> None:
        _check_kwargs('Node', kwargs, EXECUTE_PROCESS_KWARGS)
        self.executable, self.package, self.name = executable, package, name
        self.namespace, self.parameters = namespace, list(parameters or [])
        self.remappings, self.kwargs = remappings, kwargs


STAND_INS = {
    'launch': {'LaunchDescription': LaunchDescription},
    'launch.actions': {'DeclareLaunchArgument': DeclareLaunchArgument,
                       'OpaqueFunction': OpaqueFunction,
                       'IncludeLaunchDescription': IncludeLaunchDescription},
    'launch.conditions': {'IfCondition': IfCondition},
    'launch.substitutions': {'LaunchConfiguration': LaunchConfiguration,
                             'PathJoinSubstitution': PathJoinSubstitution},
    'launch.launch_description_sources': {
        'PythonLaunchDescriptionSource': PythonLaunchDescriptionSource},
    'launch_ros': {},
    'launch_ros.actions': {'Node': Node},
    'launch_ros.substitutions': {'FindPackageShare': FindPackageShare},
}


@pytest.fixture
def stand_ins(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    # The parameters files' copies (gear_phm.launching.namespaced_copy) go to tmp_path.
    monkeypatch.setattr(tempfile, 'tempdir', str(tmp_path))
    for name, members in STAND_INS.items():
        module = types.ModuleType(name)
        module.__dict__.update(members)
        monkeypatch.setitem(sys.modules, name, module)


# --- what a launch starts ----------------------------------------------------------------

def _load(path: Path) -> LaunchDescription:
    code = compile(path.read_text(encoding='utf-8'), str(path), 'exec')
    namespace: dict[str, Any] = {'__file__': str(path), '__name__': path.stem}
    exec(code, namespace)                       # noqa: S102 - as launch loads a .launch.py
    return namespace['generate_launch_description']()


def _parameters_of(node: str, params_file: str) -> dict[str, Any]:
    """Return the parameters rcl gives the node ``node`` (any namespace) from a file."""
    document = yaml.safe_load(Path(params_file).read_text(encoding='utf-8'))
    found: dict[str, Any] = {}
    for key in ('/**', f'/**/{node}'):            # rcl: wildcards first, the node's name last
        found.update(_flatten(document.get(key, {}).get('ros__parameters', {})))
    return found


def run(path: Path, **arguments: str) -> list[dict[str, Any]]:
    """Return the nodes the launch file ``path`` starts with ``arguments`` (name:=value)."""
    return list(_visit(_load(path).entities, Context(arguments)))


def _visit(entities: list[Any], context: Context) -> Iterator[dict[str, Any]]:
    for entity in entities:
        if isinstance(entity, DeclareLaunchArgument):
            if entity.name not in context:         # given, or set by an including file
                assert entity.default_value is not None, entity.name
                context[entity.name] = perform(entity.default_value, context)
            if entity.choices is not None:
                assert context[entity.name] in entity.choices, (entity.name, context)
        elif isinstance(entity, OpaqueFunction):
            yield from _visit(list(entity.function(context, *entity.args, **entity.kwargs)
                                   or []), context)
        elif isinstance(entity, IncludeLaunchDescription):
            included = Path(perform(entity.source.launch_file_path, context))
            handed = {perform(k, context): perform(v, context)
                      for k, v in entity.launch_arguments}
            # Not scoped: the included file sees the including one's configurations.
            yield from _visit(_load(included).entities, Context({**context, **handed}))
        elif isinstance(entity, Node):
            condition = entity.kwargs.get('condition')
            if condition is not None and not condition.evaluate(context):
                continue
            yield _started(entity, context)
        else:
            raise AssertionError(f'no stand-in evaluates {entity!r}')


def _started(node: Node, context: Context) -> dict[str, Any]:
    name = perform(node.name, context)
    files, parameters = [], {}
    for item in node.parameters:
        if isinstance(item, dict):              # launch_ros reads each value as YAML
            parameters.update({k: yaml.safe_load(perform(v, context)) if not isinstance(
                v, (bool, int, float)) else v for k, v in item.items()})
        else:
            path = perform(item, context)
            assert Path(path).is_file(), path
            files.append(path)
            parameters.update(_parameters_of(name, path))
    return {'package': perform(node.package, context),
            'executable': perform(node.executable, context), 'name': name,
            'namespace': perform(node.namespace, context), 'files': files,
            'parameters': parameters, 'output': node.kwargs.get('output')}


# --- what the package provides -----------------------------------------------------------

def _ros2_run_executables() -> set[str]:
    """Return what ``ros2 run gear_phm X`` finds: console_scripts installed in lib/gear_phm."""
    config = configparser.ConfigParser()
    config.read(REPO / 'setup.cfg')
    assert config['install']['install_scripts'] == '$base/lib/gear_phm'
    assert config['develop']['script_dir'] == '$base/lib/gear_phm'
    setup = ast.parse((REPO / 'setup.py').read_text(encoding='utf-8'))
    call = next(n for n in ast.walk(setup) if isinstance(n, ast.Call)
                and getattr(n.func, 'id', '') == 'setup')
    entry_points = ast.literal_eval(next(k.value for k in call.keywords
                                         if k.arg == 'entry_points'))
    return {line.split('=')[0].strip() for line in entry_points['console_scripts']}


@pytest.fixture(scope='module')
def declared() -> dict[str, set[str]]:
    """Return the parameters each node declares (docs/generate_parameter_tables.py --json)."""
    done = subprocess.run([sys.executable, str(REPO / 'docs' / 'generate_parameter_tables.py'),
                           '--json'], capture_output=True, text=True, timeout=120, cwd=REPO)
    assert done.returncode == 0, done.stderr
    return {node: {r['name'] for r in rows} | RCLPY_BUILTIN
            for node, rows in json.loads(done.stdout).items()}


def _check_parameters(started: dict[str, Any], declared: dict[str, set[str]]) -> None:
    """Each parameter given is one the node declares (a drive's keys: under its name)."""
    names = declared[started['executable']]
    drives = set(started['parameters'].get('transmissions') or ())
    for key in started['parameters']:
        drive, dot, rest = key.partition('.')
        if dot and drive in drives:
            continue                            # declared from the list (nodes/drives.py)
        assert key in names, (started['name'], key)


# --- the tests ----------------------------------------------------------------------------

def test_setup_py_installs_the_launch_files_into_share() -> None:
    setup = (REPO / 'setup.py').read_text(encoding='utf-8')
    assert "('share/' + PACKAGE_NAME + '/launch', glob('launch/*.launch.py'))" in setup
    files = sorted(p.name for p in LAUNCH.glob('*.launch.py'))
    assert files == ['bench.launch.py', 'gear_phm.launch.py']


@pytest.mark.usefixtures('stand_ins')
def test_default_launch_starts_the_three_nodes_with_the_installed_files(
        declared: dict[str, set[str]]) -> None:
    started = run(MAIN)
    assert [s['executable'] for s in started] == ['publisher', 'estimator', 'diagnostics']
    executables = _ros2_run_executables()
    for node in started:
        assert node['package'] == PACKAGE and node['executable'] in executables
        assert node['name'] == node['executable'] and node['namespace'] == ''
        assert node['output'] == 'screen'
        assert node['parameters']['use_sim_time'] is False
        _check_parameters(node, declared)
        # The copy holds the installed config/<node>.yaml, every value.
        config = yaml.safe_load((REPO / 'config' / f'{node["name"]}.yaml').read_text())
        expected = _flatten(config[node['name']]['ros__parameters'])
        assert {k: node['parameters'][k] for k in expected} == expected
    estimator = started[1]['parameters']
    assert estimator['ratio'] == 3.0 and estimator['gate_threshold'] == 10.83
    assert started[2]['parameters']['record_path'] == ''


@pytest.mark.usefixtures('stand_ins')
def test_arguments_set_namespace_sim_time_record_path_and_the_publisher(
        tmp_path: Path, declared: dict[str, set[str]]) -> None:
    estimator_file = tmp_path / 'mine.yaml'
    estimator_file.write_text('estimator:\n  ros__parameters:\n    ratio: 30.0\n')
    started = run(MAIN, namespace='rig_a', use_sim_time='true', use_publisher='false',
                  record_path=str(tmp_path / 'rec'), estimator_params_file=str(estimator_file))
    assert [s['name'] for s in started] == ['estimator', 'diagnostics']
    assert {s['namespace'] for s in started} == {'rig_a'}
    assert all(s['parameters']['use_sim_time'] is True for s in started)
    assert started[0]['parameters'] == {'ratio': 30.0, 'use_sim_time': True}
    assert started[1]['parameters']['record_path'] == str(tmp_path / 'rec')
    assert 'record_path' not in started[0]['parameters']
    for node in started:
        _check_parameters(node, declared)


@pytest.mark.usefixtures('stand_ins')
def test_bench_launch_gives_every_node_the_drives(declared: dict[str, set[str]]) -> None:
    started = run(BENCH)
    assert [s['executable'] for s in started] == ['publisher', 'estimator', 'diagnostics']
    nodes = yaml.safe_load((REPO / 'config' / 'bench_nodes.yaml').read_text())
    expected = _flatten(nodes['/**']['ros__parameters'])
    for node in started:
        assert node['parameters'] == {**expected, 'use_sim_time': False}
        _check_parameters(node, declared)
    # The CLI's transmissions file gives the same parameters.
    cli = run(BENCH, transmissions_file=str(REPO / 'config' / 'bench.yaml'),
              namespace='bench_2', use_publisher='false', record_path='/tmp/bench_2')
    assert [s['name'] for s in cli] == ['estimator', 'diagnostics']
    assert cli[0]['parameters'] == {**expected, 'use_sim_time': False}
    assert cli[1]['parameters'] == {**expected, 'use_sim_time': False,
                                    'record_path': '/tmp/bench_2'}
    assert {s['namespace'] for s in cli} == {'bench_2'}


@pytest.mark.usefixtures('stand_ins')
def test_every_argument_is_described_and_bench_hands_on_only_declared_ones() -> None:
    main = {e.name: e for e in _load(MAIN).entities if isinstance(e, DeclareLaunchArgument)}
    assert set(main) == {'namespace', 'use_sim_time', 'use_publisher', 'record_path',
                         'publisher_params_file', 'estimator_params_file',
                         'diagnostics_params_file'}
    bench_entities = _load(BENCH).entities
    bench = {e.name: e for e in bench_entities if isinstance(e, DeclareLaunchArgument)}
    for argument in (*main.values(), *bench.values()):
        assert argument.description and len(argument.description) > 10, argument.name
    include = next(e for e in bench_entities if isinstance(e, IncludeLaunchDescription))
    handed = {perform(k, Context()) for k, _ in include.launch_arguments}
    assert handed == {f'{node}_params_file' for node in ('publisher', 'estimator',
                                                         'diagnostics')}
    assert handed <= set(main)
    assert set(bench) == {'transmissions_file'}   # the others: gear_phm.launch.py's


def test_the_launch_files_use_only_the_stand_ins_names() -> None:
    """What the stand-ins cover is what the files import (a new name needs a stand-in)."""
    for path in (MAIN, BENCH):
        for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
            if isinstance(node, ast.ImportFrom) and re.match(r'launch(_ros)?\b',
                                                             node.module or ''):
                for alias in node.names:
                    assert alias.name in STAND_INS[node.module], (path.name, alias.name)
            elif isinstance(node, ast.Import):
                assert not any(a.name.startswith('launch') for a in node.names), path.name


def test_real_launch_loads_the_files() -> None:
    """Where ROS 2's launch is installed: it loads both files and lists their arguments."""
    pytest.importorskip('launch_ros')
    from launch.launch_description_sources import get_launch_description_from_python_launch_file
    expected = {MAIN: {'namespace', 'use_sim_time', 'use_publisher', 'record_path'},
                BENCH: {'transmissions_file'}}
    for path, names in expected.items():
        description = get_launch_description_from_python_launch_file(str(path))
        assert names <= {a.name for a in description.get_launch_arguments()}


@pytest.mark.usefixtures('stand_ins')
def test_the_readme_launch_commands_name_real_files_and_arguments(
        monkeypatch: pytest.MonkeyPatch, declared: dict[str, set[str]]) -> None:
    """Each `ros2 launch gear_phm` line of the README's "Launch" runs (stand-ins) as given."""
    text = (REPO / 'README.md').read_text(encoding='utf-8')
    section = re.search(r'^## Launch\n(.*?)(?=^## )', text, re.M | re.S)
    assert section, 'README has no section "## Launch"'
    lines = [line.strip() for block in re.findall(r'^```text\n(.*?)^```', section.group(1),
                                                  re.M | re.S) for line in block.splitlines()]
    monkeypatch.chdir(REPO)                     # the files given relative to the repository
    launches = [line.split()[3:] for line in lines if line.startswith('ros2 launch gear_phm ')]
    assert sorted(words[0] for words in launches) == ['bench.launch.py', 'gear_phm.launch.py']
    for file, *arguments in launches:
        given = dict(a.split(':=', 1) for a in arguments)
        started = run(LAUNCH / file, **given)
        assert started, file
        for node in started:
            _check_parameters(node, declared)
    runs = [line.split() for line in lines if line.startswith('ros2 run ')]
    assert runs == [['ros2', 'run', 'diagnostic_aggregator', 'aggregator_node', '--ros-args',
                     '--params-file', 'config/analyzers.yaml']]
    for path in re.findall(r'`((?:launch|config)/[\w.]+)`', section.group(1)):
        assert (REPO / path).is_file(), path
