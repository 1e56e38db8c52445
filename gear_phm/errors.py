"""The package's exception base: every error gear_phm raises on purpose derives from it.

Catch :class:`GearPhmError` for "any gear_phm error". The specific kinds live beside the code
that raises them (as in rosbags) and keep their older bases (``ValueError`` where they had it):

- ``gear_phm.bagio.BagError``: a bag that cannot be read;
- ``gear_phm.bagio.chunks.NotIndexed`` / ``IndexMismatch`` / ``CorruptChunk``: the fast MCAP
  reader cannot prove an answer, or a chunk is damaged;
- ``gear_phm.bagio.recover.RecoverError``: a recording that cannot be recovered;
- ``gear_phm.persistence.StateError`` / ``StateCorrupt`` / ``StateMismatch``: state files;
- ``gear_phm.sources.SourceError``: a publisher source that cannot be built;
- ``gear_phm.offline.AnalysisError`` / ``gear_phm.offline.fleet.FleetError``: offline input;
- ``gear_phm.offline.truth.TruthError`` / ``gear_phm.offline.evaluation.EvaluationError``: a
  run that cannot be scored against its ground truth;
- ``gear_phm.jsonfields.RecordError``: a JSON document that is not the record it should be
  (a summary.json read back);
- ``gear_phm.transmissions.TransmissionsError``: a list of many drives (transmissions file);
- ``gear_phm.models.ModelError``: an argument outside a model function's domain;
- ``gear_phm.nodes.common.ConfigError``: a node's start-up configuration;
- ``gear_phm.cli.main.CliError``: a command line.
"""
from __future__ import annotations


class GearPhmError(Exception):
    """Base of every exception gear_phm raises on purpose; ``str()`` is one line for a user."""
