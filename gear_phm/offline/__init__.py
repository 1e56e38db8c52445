"""Offline analysis of recorded bags with the live nodes' code: the Python API.

In a notebook::

    from gear_phm.offline import analyze_bag
    analysis = analyze_bag('bags/wearing', ratio=3.0, eta_opposing_min=0.7333)
    analysis.estimates.u[-1], analysis.health.rul_p5[-1], analysis.summary['health']['level']
    frame = analysis.to_dataframe()          # with pandas installed

``gear-phm analyze`` is a thin command-line wrapper around :func:`analyze_bag`.
"""
from gear_phm.offline.engine import AnalysisError, analyze_bag, split_options
from gear_phm.offline.parallel import ParallelError
from gear_phm.offline.records import Analysis, EstimateHistory, HealthHistory

__all__ = ['Analysis', 'AnalysisError', 'EstimateHistory', 'HealthHistory', 'ParallelError',
           'analyze_bag', 'split_options']
