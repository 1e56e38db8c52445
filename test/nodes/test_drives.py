"""The parameters of a node serving many drives (gear_phm.nodes.drives)."""
from __future__ import annotations

from types import SimpleNamespace

from gear_phm.nodes.drives import LIVE_WITH_DRIVES, refuse_changes


def test_only_the_clock_switch_and_the_frame_id_change_at_run_time() -> None:
    assert LIVE_WITH_DRIVES == ('use_sim_time', 'frame_id')
    live = [SimpleNamespace(name=name) for name in LIVE_WITH_DRIVES]
    assert refuse_changes(live).successful
    assert refuse_changes([]).successful
    refused = refuse_changes([*live, SimpleNamespace(name='window'),
                              SimpleNamespace(name='ratio')])
    assert not refused.successful
    assert refused.reason.startswith('window, ratio: with transmissions the parameters are '
                                     'read at start only')
