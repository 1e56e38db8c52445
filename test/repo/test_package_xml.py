"""package.xml declares every package that gear_phm/, launch/ and the suite import.

rosdep resolves each ``*_depend`` key of package.xml: a ROS package of the distribution or
a key of rosdep's own rules (ros/rosdistro rosdep/python.yaml, base.yaml). The tables below
map each imported top-level name to its key; :data:`ROSDEP_KEYS` lists the keys that were
looked up in rosdep/python.yaml, so that no invented key (one rosdep cannot resolve) slips in.
"""
from __future__ import annotations

import ast
from collections.abc import Iterator
import configparser
from pathlib import Path
import re
import sys

from catkin_pkg.package import parse_package
import pytest

REPO = Path(__file__).resolve().parents[2]
PACKAGE = 'gear_phm'

#: Run-time imports of gear_phm/ and launch/ -> their exec_depend key.
RUN_IMPORTS = {
    'rclpy': 'rclpy',
    'rcl_interfaces': 'rcl_interfaces',
    'builtin_interfaces': 'builtin_interfaces',
    'std_msgs': 'std_msgs',
    'sensor_msgs': 'sensor_msgs',
    'geometry_msgs': 'geometry_msgs',
    'diagnostic_msgs': 'diagnostic_msgs',
    'rosgraph_msgs': 'rosgraph_msgs',
    'lifecycle_msgs': 'lifecycle_msgs',
    'std_srvs': 'std_srvs',
    'launch': 'launch',
    'launch_ros': 'launch_ros',
    'ament_index_python': 'ament_index_python',
    'numpy': 'python3-numpy',
    'yaml': 'python3-yaml',
    'matplotlib': 'python3-matplotlib',
    'tqdm': 'python3-tqdm',
    'filterpy': 'python3-filterpy-pip',
    'rosbags': 'python3-rosbags-pip',
}
#: Run-time imports without a rosdep key -> their name in setup.py install_requires.
PIP_ONLY = {'mcap': 'mcap', 'lz4': 'lz4', 'zstandard': 'zstandard'}
#: Optional: imported only inside the functions that need them, never at module level.
OPTIONAL = frozenset({'dask', 'pandas', 'pyarrow'})
#: Imports of the suite (test/, docs/) only -> their test_depend key (None: a pip
#: requirement, no rosdep key).
TEST_IMPORTS = {
    'pytest': 'python3-pytest',
    'hypothesis': 'python3-hypothesis',
    'scipy': 'python3-scipy',
    'catkin_pkg': 'python3-catkin-pkg',
    'ament_flake8': 'ament_flake8',
    'ament_pep257': 'ament_pep257',
}
#: Plugins setup.cfg's pytest configuration needs -> (what uses them, test_depend key).
PYTEST_PLUGINS = {'-n': 'python3-pytest-xdist', 'timeout': 'python3-pytest-timeout'}
#: Keys of rosdep/python.yaml (ros/rosdistro) this package uses, each looked up there.
ROSDEP_KEYS = frozenset({
    'python3-numpy', 'python3-yaml', 'python3-matplotlib', 'python3-tqdm',
    'python3-filterpy-pip', 'python3-rosbags-pip', 'python3-mypy', 'python3-types-pyyaml',
    'python3-pytest', 'python3-pytest-xdist', 'python3-pytest-timeout', 'python3-hypothesis',
    'python3-scipy', 'python3-catkin-pkg', 'python3-colcon-common-extensions',
})
#: ROS 2 Jazzy packages this package uses (jazzy/distribution.yaml).
ROS_PACKAGES = frozenset(v for v in RUN_IMPORTS.values() if not v.startswith('python3-')) \
    | {'ros2launch', 'ament_flake8', 'ament_pep257'}


def _modules(folder: Path) -> Iterator[Path]:
    yield from (p for p in sorted(folder.rglob('*.py')) if '__pycache__' not in p.parts)


def _imports(path: Path) -> Iterator[tuple[str, bool]]:
    """(top-level name, imported at module level) of each absolute import in ``path``."""
    tree = ast.parse(path.read_text(encoding='utf-8'))
    nested = {id(n) for f in ast.walk(tree)
              if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef))
              for n in ast.walk(f) if n is not f}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        else:
            continue
        for name in names:
            yield name.partition('.')[0], id(node) not in nested


def _third_party(folders: list[Path], local: set[str]) -> dict[str, set[str]]:
    """Return {imported top-level name: {'module level', 'in a function'}} of ``folders``."""
    found: dict[str, set[str]] = {}
    for folder in folders:
        for path in _modules(folder):
            for name, top in _imports(path):
                if name in sys.stdlib_module_names or name in local or name == '__future__':
                    continue
                found.setdefault(name, set()).add('module level' if top else 'in a function')
    return found


def _local_names() -> set[str]:
    """Names the suite imports from its own folders (helpers, bench scripts, ...)."""
    names = {PACKAGE}
    for folder in ('test', 'bench', 'docs'):
        for path in _modules(REPO / folder):
            names.add(path.stem)
            names.update(part for part in path.relative_to(REPO / folder).parts[:-1])
    return names


@pytest.fixture(scope='module')
def package():  # noqa: ANN201 - catkin_pkg is untyped
    manifest = parse_package(str(REPO / 'package.xml'))
    manifest.validate()
    return manifest


def _keys(depends: list) -> set[str]:
    return {d.name for d in depends}


def test_every_run_time_import_is_declared(package) -> None:  # noqa: ANN001
    run = _keys(package.exec_depends) | _keys(package.build_export_depends)
    imports = _third_party([REPO / PACKAGE, REPO / 'launch'], {PACKAGE})
    unknown = sorted(set(imports) - set(RUN_IMPORTS) - set(PIP_ONLY) - OPTIONAL)
    assert not unknown, f"imports with no entry in this test's tables: {unknown}"
    missing = sorted(f'{name} ({RUN_IMPORTS[name]})' for name in imports
                     if name in RUN_IMPORTS and RUN_IMPORTS[name] not in run)
    assert not missing, f'imported, not an exec_depend of package.xml: {missing}'
    at_module_level = sorted(name for name in OPTIONAL & set(imports)
                             if 'module level' in imports[name])
    assert not at_module_level, f'optional, yet imported at module level: {at_module_level}'
    # The launch files and the nodes are what this table covers; it must have found them.
    assert {'rclpy', 'launch', 'launch_ros', 'numpy'} <= set(imports)


def test_pip_only_imports_are_install_requires_not_invented_keys(package) -> None:  # noqa
    setup = (REPO / 'setup.py').read_text(encoding='utf-8')
    requires = {re.split(r'[<>=!~ ]', r)[0].lower()
                for r in re.findall(r"'([A-Za-z0-9_.-]+[<>=!~][^']*)'", setup)}
    assert set(PIP_ONLY.values()) <= requires, requires
    declared = {d.name for d in package.exec_depends + package.test_depends
                + package.build_depends + package.buildtool_depends}
    for name in PIP_ONLY:
        assert not any(name in key for key in declared), (name, declared)


def test_every_key_is_a_rosdep_key_or_a_ros_package(package) -> None:  # noqa: ANN001
    depends = (package.exec_depends + package.test_depends + package.build_depends
               + package.buildtool_depends + package.build_export_depends)
    keys = _keys(depends)
    assert keys - ROSDEP_KEYS - ROS_PACKAGES == set()
    assert 'python3-mcap-pip' not in keys
    assert package.get_build_type() == 'ament_python'


def test_every_suite_import_is_a_dependency(package) -> None:  # noqa: ANN001
    keys = _keys(package.exec_depends) | _keys(package.test_depends)
    imports = _third_party([REPO / 'test', REPO / 'docs'], _local_names())
    known = set(RUN_IMPORTS) | set(PIP_ONLY) | OPTIONAL | set(TEST_IMPORTS)
    assert sorted(set(imports) - known) == []
    missing = sorted(f'{name} ({TEST_IMPORTS[name]})' for name in imports
                     if name in TEST_IMPORTS and TEST_IMPORTS[name] not in keys)
    assert not missing, f'imported by the suite, not a test_depend: {missing}'


def test_pytest_plugins_of_setup_cfg_are_test_depends(package) -> None:  # noqa: ANN001
    config = configparser.ConfigParser()
    config.read(REPO / 'setup.cfg')
    pytest_config = config['tool:pytest']
    tests = _keys(package.test_depends)
    assert '-n ' in pytest_config['addopts'] and 'timeout' in pytest_config
    assert set(PYTEST_PLUGINS.values()) <= tests
    assert 'python3-mypy' in tests and 'ament_flake8' in tests and 'ament_pep257' in tests
