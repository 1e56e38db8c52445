"""Status names under a namespace (gear_phm.nodes.common.qualified)."""
from __future__ import annotations

from typing import Any

import pytest

pytest.importorskip('rclpy')
from gear_phm.nodes.common import qualified  # noqa: E402


class _Named:
    def __init__(self, namespace: str) -> None:
        self.namespace = namespace

    def get_namespace(self) -> str:
        return self.namespace


@pytest.mark.parametrize('namespace, expected', [('/', 'gearbox'), ('/r1', 'r1/gearbox'),
                                                 ('/fleet/r2', 'fleet/r2/gearbox')])
def test_default_names_are_unique_under_a_namespace(namespace: str, expected: str) -> None:
    node: Any = _Named(namespace)
    assert qualified(node, 'gearbox') == expected
