"""``analyze_bag``'s options as one frozen record, and the drives they set up."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from gear_phm.offline import AnalysisError, analyze_bag, AnalyzeOptions
from gear_phm.offline.options import drive_setups
from gear_phm.run import DriveNames

ROOT = Path(__file__).resolve().parents[2]


def test_keywords_sort_into_fields_and_parameters() -> None:
    options = AnalyzeOptions.of(3.0, plot=False, jobs=2, eta_opposing_min=0.7333)
    assert (options.ratio, options.plot, options.jobs) == (3.0, False, 2)
    assert options.parameters == {'eta_opposing_min': 0.7333}
    with pytest.raises(dataclasses.FrozenInstanceError):
        options.ratio = 4.0  # type: ignore[misc]
    (setup,) = drive_setups(options)
    # hardware_id: the transmission's name, as the live diagnostics node's default
    assert setup.names == DriveNames.single(hardware_id=DriveNames.single().transmission_name)
    assert setup.estimator_config.ratio == 3.0 and setup.health_config.eta_opposing_min == 0.7333


def test_each_listed_drive_is_set_up_with_its_own_names() -> None:
    setups = drive_setups(AnalyzeOptions(transmissions=ROOT / 'config' / 'bench.yaml',
                                         parameters={'eta_opposing_min': 0.7}))
    assert [s.names for s in setups] == [DriveNames.of(d)
                                         for d in ('flap_l', 'spoiler_3', 'rudder')]
    assert [s.health_config.eta_opposing_min for s in setups] == [0.6, 0.7, 0.7]


def test_bad_options_are_refused_with_their_reason() -> None:
    with pytest.raises(AnalysisError, match='unknown option'):
        drive_setups(AnalyzeOptions.of(3.0, eta_opossing_min=0.7))
    with pytest.raises(AnalysisError, match='give the ratio'):
        drive_setups(AnalyzeOptions())
    with pytest.raises(AnalysisError, match='history must be'):
        AnalyzeOptions(3.0, history=0).checked()
    with pytest.raises(AnalysisError, match='options or keywords, not both'):
        analyze_bag(ROOT / 'bags' / 'healthy', AnalyzeOptions(3.0), plot=False)


def test_options_and_keywords_analyse_alike() -> None:
    """``analyze_bag(bags, options)`` is ``analyze_bag(bags, ratio, **keywords)``."""
    bag = ROOT / 'bags' / 'fault'
    by_keywords = analyze_bag(bag, 3.0, plot=False, history=50, eta_opposing_min=0.7333)
    by_options = analyze_bag(bag, AnalyzeOptions(3.0, plot=False, history=50,
                                                 parameters={'eta_opposing_min': 0.7333}))
    ours, theirs = (a.summary.to_dict() for a in (by_options, by_keywords))
    for summary in (ours, theirs):
        summary.pop('seconds')
        summary.pop('samples_per_second')
    assert ours == theirs
    assert by_options.estimates.u.tolist() == by_keywords.estimates.u.tolist()
