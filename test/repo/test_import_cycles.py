"""No import cycles between the modules of gear_phm.

Every import counts: module level, inside functions (a deferred import hides a cycle, it does
not remove it) and under ``if TYPE_CHECKING`` (the types still depend on each other).
"""
from __future__ import annotations

import ast
from pathlib import Path

import gear_phm

ROOT = Path(gear_phm.__file__).parent


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT.parent).with_suffix('').parts)
    return '.'.join(parts[:-1] if parts[-1] == '__init__' else parts)


def _imports(tree: ast.AST, name: str, is_package: bool, modules: set[str]) -> set[str]:
    """Modules of gear_phm that ``name`` imports, anywhere in its source."""
    found: set[str] = set()
    stack: list[ast.AST] = [tree]
    while stack:
        node = stack.pop()
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ''
            if node.level:
                package = name if is_package else name.rpartition('.')[0]
                for _ in range(node.level - 1):
                    package = package.rpartition('.')[0]
                base = f'{package}.{base}' if base else package
            for alias in node.names:
                child = f'{base}.{alias.name}'
                found.add(child if child in modules else base)
        stack.extend(ast.iter_child_nodes(node))
    return {module for module in found if module in modules and module != name}


def import_graph() -> dict[str, set[str]]:
    """Map each module of gear_phm to the gear_phm modules it imports."""
    files = {_module_name(path): path for path in ROOT.rglob('*.py')}
    modules = set(files)
    return {name: _imports(ast.parse(path.read_text()), name, path.name == '__init__.py',
                           modules) for name, path in files.items()}


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Return the strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in sorted(graph[node]):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                on_stack.discard(top)
                component.append(top)
                if top == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def test_the_checker_finds_a_cycle() -> None:
    graph = {'a': {'b'}, 'b': {'c'}, 'c': {'a'}, 'd': {'a'}}
    assert cycles(graph) == [['a', 'b', 'c']]


def test_no_import_cycle_in_gear_phm() -> None:
    graph = import_graph()
    assert len(graph) > 40
    assert 'gear_phm.estimation.kalman' in graph['gear_phm.estimation.pipeline']
    assert cycles(graph) == []
