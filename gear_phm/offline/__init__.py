"""Offline analysis of recorded bags with the live nodes' code: the Python API.

In a notebook::

    from gear_phm.offline import analyze_bag
    analysis = analyze_bag('bags/wearing', ratio=3.0, eta_opposing_min=0.7333)
    analysis.estimates.u[-1], analysis.health.rul_p5[-1], analysis.summary.health.level
    analysis.summary.estimator.u, analysis.summary.health.value('rul_s')
    frame = analysis.to_dataframe()          # with pandas installed

``analysis.summary`` is a :class:`~gear_phm.offline.summary.DriveSummary` (many drives: a
:class:`~gear_phm.offline.summary.RunSummary`, each drive's in ``transmissions``);
:func:`~gear_phm.offline.summary.read_summary` reads a summary.json back.

``gear-phm analyze`` is a thin command-line wrapper around :func:`analyze_bag`.
"""
from gear_phm.offline.engine import analyze, analyze_bag
from gear_phm.offline.options import AnalysisError, AnalyzeOptions, split_options
from gear_phm.offline.parallel import ParallelError
from gear_phm.offline.records import Analysis, EstimateHistory, HealthHistory
from gear_phm.offline.summary import (DriveSummary, HealthSummary, read_summary, RunInfo,
                                      RunSummary, TrendSummary)

__all__ = ['Analysis', 'AnalysisError', 'AnalyzeOptions', 'DriveSummary', 'EstimateHistory',
           'HealthHistory', 'HealthSummary', 'ParallelError', 'RunInfo', 'RunSummary',
           'TrendSummary', 'analyze', 'analyze_bag', 'read_summary', 'split_options']
