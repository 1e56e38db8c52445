"""Many transmissions: one folder of recordings per unit, analysed in parallel on Dask.

:func:`analyze_fleet` finds the units (the sub-folders of a root), runs
:func:`~gear_phm.offline.analyze_bag` over each unit's recordings as one campaign, on a Dask
cluster (a local one sized to the machine, or an existing one by its scheduler address), and
writes the fleet table (Parquet and CSV, one row per unit) and the fleet plot. Each unit is one
Dask task, so a unit's result does not depend on the number of workers or the order in which
they finish: the table of a run on 2 workers is byte for byte the table of a serial run.

A unit folder holds rosbag2 directories and/or ``.mcap``, ``.db3``, ``.bag`` files, and an
optional ``unit.yaml`` of per-unit options (``ratio``, ``motor_joint``, ``load_joint``,
``topic``, and any estimator or health parameter by name: :func:`option_specs`), which override
the fleet-wide ones. A unit with many drives in one stream lists them under ``transmissions``
in its ``unit.yaml`` (:mod:`gear_phm.transmissions`): it gets one row per drive, named
``<unit>/<drive>``. A unit that cannot be analysed (no recording, a corrupt bag, bad options)
gets a row with level ``FAILED`` and the reason; the others complete. The fleet-wide options
are checked before any unit runs, and the output directory is written whole or not at all.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
import csv
from dataclasses import asdict, dataclass, replace
import json
import math
from pathlib import Path
import resource
import sys
from typing import Any

import numpy as np

from gear_phm import stopping
from gear_phm.errors import GearPhmError
from gear_phm.interfaces import JOINT_STATES
from gear_phm.offline.records import Analysis
from gear_phm.offline.summary import DriveSummary
from gear_phm.parameters import (DIAGNOSTICS_RATE, HARDWARE_ID, LOAD_JOINT, MOTOR_JOINT,
                                 ParamSpec, RATIO, STAMP_SOURCE, TRANSMISSION_NAME)
from gear_phm.prognostics import ShapePrior
from gear_phm.prognostics.laws import SHAPED
from gear_phm.staging import Staged
from gear_phm.transmissions import (DRIVE_OWN, drive_own_given, parse_transmissions,
                                    read_yaml, TRANSMISSIONS, TransmissionsError)

#: Columns of the fleet table, in order. ``rul_operating_*`` [s of operation] is the RUL the
#: trend gives (operating time: wear accrues only while a unit moves); ``rul_*`` [s] is the
#: same in elapsed time at the unit's utilisation so far (the /diagnostics keys of that name).
OPERATING_RUL = ('rul_operating_s', 'rul_operating_p5_s', 'rul_operating_p95_s')
HEALTH_VALUES = (*OPERATING_RUL, 'rul_s', 'rul_p5_s', 'rul_p95_s', 'utilisation')
#: The no-load model's values of a unit (NaN without ``no_load_model``): the no-load torque
#: at the motor at the reference speed [N m] and the total efficiency at the rated point.
NO_LOAD_VALUES = ('no_load_torque', 'total_efficiency')
COLUMNS = ('unit', 'recordings', 'operating_time_s', 'u', 'u_sigma', 'eta_opposing',
           'eta_aiding', *HEALTH_VALUES, 'level', 'reason', *NO_LOAD_VALUES)
#: Points of each unit's u trend kept for the fleet plot.
TREND_POINTS = 200
#: Units at end of life needed before their wear law becomes the fleet's prior.
PRIOR_MIN_UNITS = 3
#: Floor of the prior's spread of log(shape) [-]: a few units do not pin the shape exactly.
PRIOR_MIN_LOG_SIGMA = 0.1
#: Seconds to wait for an existing Dask scheduler (``--scheduler``) to answer.
CONNECT_TIMEOUT = 10.0
#: A unit's options besides the estimator and health parameters: analyze_bag's keywords.
UNIT_SPECS = (RATIO, MOTOR_JOINT, LOAD_JOINT, TRANSMISSION_NAME, HARDWARE_ID,
              replace(DIAGNOSTICS_RATE, name='diagnostics_rate'), STAMP_SOURCE,
              ParamSpec('topic', JOINT_STATES, 'the JointState topic'))


def population_prior(summaries: Sequence[DriveSummary | None]) -> ShapePrior | None:
    """Return the fleet's wear-law prior from its units' summaries (None: a failed unit), or None.

    The units at end of life (u >= u_eol) whose fitted law has a shape (exponential, power or
    proportional) vote; the law of most votes, with at least :data:`PRIOR_MIN_UNITS`, gives
    the prior: the mean and the spread (at least :data:`PRIOR_MIN_LOG_SIGMA`) of their log
    shapes. A linear law has no shape, so a fleet that wears linearly gets no prior.
    """
    shapes: dict[str, list[float]] = {}
    for summary in summaries:
        trend = None if summary is None or not summary.at_end_of_life else summary.health.trend
        if trend is not None and trend.model in SHAPED and trend.shape > 0.0:
            shapes.setdefault(trend.model, []).append(math.log(trend.shape))
    if not shapes:
        return None
    model, logs = max(shapes.items(), key=lambda item: (len(item[1]), item[0]))
    if len(logs) < PRIOR_MIN_UNITS:
        return None
    spread = float(np.std(logs, ddof=1))
    return ShapePrior(model, float(np.mean(logs)), max(spread, PRIOR_MIN_LOG_SIGMA))


def _at_end_of_life(summary: DriveSummary | None) -> bool:
    return summary is not None and summary.at_end_of_life


class FleetError(GearPhmError, ValueError):
    """The fleet as a whole cannot be analysed (e.g. no unit folder): one line."""


@dataclass(frozen=True)
class UnitResult:
    """One unit: its row, its u trend (operating time [s], u, sigma), the worker's peak RSS."""

    row: dict[str, Any]
    trend: tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]
    peak_rss_mib: float
    #: The analysis's summary (None for a FAILED unit): the fitted wear law
    #: (``health.trend``) feeds :func:`population_prior`.
    summary: DriveSummary | None = None
    #: The population prior the unit was analysed with (None: none).
    prior: ShapePrior | None = None


def option_specs() -> dict[str, ParamSpec]:
    """Return the spec of each option of a unit by name (``transmissions`` aside).

    The estimator and health parameters that ``gear-phm analyze`` takes, and
    :data:`UNIT_SPECS`.
    """
    from gear_phm.estimation.config import PARAMETERS as ESTIMATOR_PARAMETERS
    from gear_phm.prognostics.config import NOT_OFFLINE_OPTIONS
    from gear_phm.prognostics.config import PARAMETERS as HEALTH_PARAMETERS
    return {**{spec.name: spec for spec in (*ESTIMATOR_PARAMETERS, *HEALTH_PARAMETERS)
               if spec.name not in NOT_OFFLINE_OPTIONS},
            **{spec.name: spec for spec in UNIT_SPECS}}


def check_options(options: Mapping[Any, Any]) -> dict[str, Any]:
    """Return ``options`` with each value checked by the spec of its name.

    ValueError names the first unknown option or bad value; ``transmissions`` must be a list
    of drives (:func:`gear_phm.transmissions.parse_transmissions`). The rules between
    parameters are :func:`check_configs`'.
    """
    specs = option_specs()
    checked: dict[str, Any] = {}
    for name, value in options.items():
        if name == TRANSMISSIONS:
            try:
                parse_transmissions({TRANSMISSIONS: value})
            except TransmissionsError as exc:
                raise ValueError(str(exc)) from None
            checked[name] = value
        elif name in specs:
            checked[name] = specs[name].check(value)
        else:
            msg = (f'unknown option {name!r}; known: {TRANSMISSIONS}, '
                   f'{", ".join(sorted(specs))}')
            raise ValueError(msg)
    return checked


def check_configs(options: Mapping[str, Any]) -> None:
    """Check the estimator and health parameters of checked ``options`` together.

    As ``gear-phm analyze`` does (:func:`gear_phm.offline.options.split_options`); without a
    ratio, with the smallest one, so that only a rule that no ratio satisfies fails.
    AnalysisError (a ValueError) if they are inconsistent.
    """
    from gear_phm.offline.options import split_options
    unit_names = {spec.name for spec in UNIT_SPECS}
    split_options(options.get(RATIO.name, RATIO.low), {
        name: value for name, value in options.items()
        if name not in unit_names and name != TRANSMISSIONS})


def discover_units(root: Path) -> list[Path]:
    """Return the unit folders: the sub-directories of ``root`` that are not themselves a bag."""
    if not root.is_dir():
        raise FleetError(f'fleet root {root} is not a directory')
    units = [p for p in sorted(root.iterdir())
             if p.is_dir() and not (p / 'metadata.yaml').is_file() and not p.name.startswith('.')]
    if not units:
        raise FleetError(f'fleet root {root} has no unit folder (one sub-folder per unit)')
    return units


def unit_options(unit: Path, fleet_options: dict[str, Any]) -> dict[str, Any]:
    """Fleet-wide options overridden by the unit's ``unit.yaml`` (ValueError if malformed).

    The file is read as a transmissions file is (:func:`gear_phm.transmissions.read_yaml`: a
    key given twice is refused). Each value is checked (:func:`check_options`), and with the
    fleet-wide ones (:func:`check_configs`); the ValueError names the file.
    With ``transmissions`` there, the file must not set a ratio, joints or names (each drive
    has its own).
    """
    options = dict(fleet_options)
    path = unit / 'unit.yaml'
    if not path.is_file():
        return options
    loaded = read_yaml(path)    # TransmissionsError, a ValueError naming the file
    if loaded is None:
        loaded = {}
    if not isinstance(loaded, dict):
        msg = f'{path}: expected a mapping of option: value'
        raise ValueError(msg)
    try:
        own = check_options(loaded)
    except ValueError as exc:
        msg = f'{path}: {exc}'
        raise ValueError(msg) from None
    if TRANSMISSIONS in own:
        refusal = drive_own_given([name for name in DRIVE_OWN if name in own])
        if refusal:
            msg = f'{path}: {refusal}'
            raise ValueError(msg)
    options.update(own)
    if TRANSMISSIONS not in options:        # (each drive's own are checked as it is read)
        try:
            check_configs(options)
        except ValueError as exc:
            msg = f'{path}: {exc}'
            raise ValueError(msg) from None
    return options


def _failed(name: str, recordings: int, reason: str) -> dict[str, Any]:
    row: dict[str, Any] = {column: math.nan for column in COLUMNS}
    row.update(unit=name, recordings=recordings, level='FAILED', reason=reason)
    return row


def analyze_unit(unit: Path, fleet_options: dict[str, Any],
                 out: Path | None = None, prior: ShapePrior | None = None) -> list[UnitResult]:
    """One unit's rows (never raises on the unit's data: a failure is a FAILED row).

    One row, or with ``transmissions`` in its ``unit.yaml`` one row per drive, named
    ``<unit>/<drive>`` (the fleet-wide ratio and joints are then not used). ``prior``: the
    fleet's population prior on the wear law's shape, if any.
    """
    from gear_phm.bagio.discovery import recordings_in
    from gear_phm.offline.engine import analyze_bag
    from gear_phm.offline.options import AnalysisError
    recordings = recordings_in(unit)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    empty: tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]] = ((), (), ())
    if not recordings:
        return [UnitResult(_failed(unit.name, 0, f'no recording in {unit}'), empty, peak)]
    try:
        options = unit_options(unit, fleet_options)
        if TRANSMISSIONS in options:          # the fleet-wide ratio and joints do not apply
            options = {k: v for k, v in options.items()
                       if k not in ('ratio', 'motor_joint', 'load_joint')}
            options[TRANSMISSIONS] = {TRANSMISSIONS: options[TRANSMISSIONS]}
            ratio = None
        else:
            ratio = options.pop('ratio', None)
            if ratio is None:
                raise ValueError('no ratio: give --ratio or ratio in unit.yaml')
            ratio = float(ratio)
        # the histories only feed the trend: bounded, so that a worker's memory does not grow
        # with the unit's number of recordings
        analysis = analyze_bag(recordings, ratio, out=out, plot=False, progress=False,
                               history=TREND_POINTS, prior=prior,
                               overwrite=prior is not None, **options)
    except (AnalysisError, ValueError, TypeError, OSError) as exc:
        return [UnitResult(_failed(unit.name, len(recordings), ' '.join(str(exc).split())),
                           empty, peak)]
    except Exception as exc:    # a bug met on this unit's data: this unit fails, not the fleet
        reason = f'unexpected {type(exc).__name__}: {" ".join(str(exc).split())}'
        return [UnitResult(_failed(unit.name, len(recordings), reason), empty, peak)]
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    if not analysis.transmissions:
        return [_result(unit.name, len(recordings), analysis, peak, prior)]
    return [_result(f'{unit.name}/{drive}', len(recordings), drive_analysis, peak, prior)
            for drive, drive_analysis in analysis.transmissions.items()]


def _result(name: str, recordings: int, analysis: Analysis, peak: float,
            prior: ShapePrior | None) -> UnitResult:
    """Return the row of one transmission's Analysis (a unit's, or one drive of a unit)."""
    s = analysis.summary
    assert isinstance(s, DriveSummary), 'one transmission'
    health, estimator = s.health, s.estimator
    row = {'unit': name, 'recordings': recordings,
           'operating_time_s': estimator.operating_time_s,
           'u': estimator.u, 'u_sigma': estimator.sigma_u,
           'eta_opposing': estimator.eta_opposing, 'eta_aiding': estimator.eta_aiding,
           **{key: health.value(key) for key in HEALTH_VALUES},
           'level': health.level, 'reason': health.message or '',
           **{key: estimator.extra_number(key) for key in NO_LOAD_VALUES}}
    e = analysis.estimates
    keep = np.unique(np.linspace(0, e.u.size - 1, min(TREND_POINTS, e.u.size)).astype(int))
    clock = e.operating_time if np.all(np.isfinite(e.operating_time)) else e.t - e.t[0]
    trend = (tuple(clock[keep].tolist()), tuple(e.u[keep].tolist()),
             tuple(e.u_sigma[keep].tolist()))
    return UnitResult(row, trend, peak, s, prior)


def run_units(units: Sequence[Path], options: dict[str, Any], out: Path | None,
              scheduler: str | None, workers: int | None,
              on_done: Callable[[], None] = lambda: None,
              population: bool = False,
              timeout: float = CONNECT_TIMEOUT,
              on_start: Callable[[int], None] = lambda workers: None) -> list[UnitResult]:
    """Analyse each unit as one Dask task; results in unit order.

    ``on_start`` is called once the cluster is there, with its number of workers, ``on_done``
    as each unit completes.

    ``scheduler``: address of an existing cluster (FleetError if it does not answer within
    ``timeout`` [s]), else a local one with ``workers`` processes (default: one per core), at
    most one per unit (a worker without a unit would only cost its start-up).
    With ``population``, the units at end of life then give the fleet's prior
    (:func:`population_prior`) and the others are analysed again with it, as a second round
    of tasks.
    """
    import os
    import tempfile
    from dask.distributed import Client, LocalCluster, as_completed
    outs = [None if out is None else out / 'units' / unit.name for unit in units]
    scratch: tempfile.TemporaryDirectory[str] | None = None
    cluster: LocalCluster | None = None
    client: Client | None = None
    try:            # the cluster closed, its scratch folder removed, also if interrupted here
        if scheduler:
            try:
                client = Client(scheduler, timeout=timeout)
            except (OSError, ValueError, TypeError) as exc:
                msg = (f'cannot connect to the Dask scheduler at {scheduler}: '
                       f'{" ".join(str(exc).split()) or type(exc).__name__}')
                raise FleetError(msg) from None
        else:
            scratch = tempfile.TemporaryDirectory(prefix='gear-phm-dask-')   # not in the cwd
            cluster = LocalCluster(n_workers=min(workers or os.cpu_count() or 1,
                                                 max(len(units), 1)),
                                   threads_per_worker=1, processes=True,
                                   dashboard_address=None, silence_logs=40,
                                   local_directory=scratch.name,    # no fixed port (8787):
                                   scheduler_kwargs={'dashboard_address': ':0'})
            client = Client(cluster)
        on_start(len(client.scheduler_info()['workers']))
        futures = [client.submit(analyze_unit, unit, options, unit_out, pure=False,
                                 key=f'gear-phm-unit-{unit.name}-{i}')
                   for i, (unit, unit_out) in enumerate(zip(units, outs))]
        order = {future.key: i for i, future in enumerate(futures)}
        results: list[list[UnitResult]] = [[] for _ in futures]
        for future in as_completed(futures):
            stopping.check()                # a signal's stop that was swallowed
            results[order[future.key]] = future.result()
            on_done()
        prior = (population_prior([r.summary for rows in results for r in rows])
                 if population else None)
        if prior is None:
            return [r for rows in results for r in rows]

        def running(r: UnitResult) -> bool:
            return r.row['level'] != 'FAILED' and not _at_end_of_life(r.summary)
        again = [i for i, rows in enumerate(results) if any(running(r) for r in rows)]
        futures = [client.submit(analyze_unit, units[i], options, outs[i], prior, pure=False,
                                 key=f'gear-phm-unit-prior-{units[i].name}-{i}') for i in again]
        for i, rows in zip(again, client.gather(futures)):
            before = results[i]
            if len(rows) == len(before):
                # a drive at its end of life keeps the result it taught the prior with
                rows = [new if running(old) else old for old, new in zip(before, rows)]
            results[i] = rows
        return [r for rows in results for r in rows]
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
        if scratch is not None:
            scratch.cleanup()


def write_table(rows: list[dict[str, Any]], out: Path) -> None:
    """``fleet.csv`` and ``fleet.parquet`` (one row per unit, :data:`COLUMNS`)."""
    with open(out / 'fleet.csv', 'w', newline='') as handle:
        writer = csv.DictWriter(handle, fieldnames=COLUMNS)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: (repr(v) if isinstance(v, float) else v) for k, v in row.items()})
    import pyarrow as pa
    import pyarrow.parquet as pq
    table = pa.table({column: [row[column] for row in rows] for column in COLUMNS})
    pq.write_table(table, out / 'fleet.parquet')


def plot_fleet(results: list[UnitResult], path: Path, title: str) -> None:
    """Plot units ranked by operating-time RUL with p5-p95 bands, and u against operating time."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    ok = [r for r in results if r.row['level'] != 'FAILED']
    ranked = sorted(ok, key=lambda r: (r.row['rul_operating_s'], r.row['unit']))
    fig, (ax_rul, ax_u) = plt.subplots(1, 2, figsize=(13, max(4.0, 0.28 * len(ranked) + 2)))
    colours = {'OK': 'C2', 'WARN': 'C1', 'ERROR': 'C3', 'STALE': 'C7'}
    finite_hi = [r.row['rul_operating_p95_s'] for r in ranked
                 if math.isfinite(r.row['rul_operating_p95_s'])]
    cap = max(finite_hi) * 1.1 if finite_hi else 1.0
    for y, r in enumerate(ranked):
        row = r.row
        median, p5, p95 = (min(row[k], cap) if math.isfinite(row[k]) else cap
                           for k in OPERATING_RUL)
        colour = colours.get(row['level'], 'k')
        ax_rul.plot([p5, p95], [y, y], color=colour, lw=4, alpha=0.4)
        ax_rul.plot([median], [y], 'o', color=colour)
    ax_rul.set_yticks(range(len(ranked)), [r.row['unit'] for r in ranked], fontsize=7)
    ax_rul.set_xlabel('RUL [s of operation] (median, p5-p95; beyond the axis = no wear '
                      'detected)')
    ax_rul.set_title('units ranked by RUL (colour = level)')
    ax_rul.grid(alpha=0.3)
    for r in ranked:
        t, u, _ = (np.array(v) for v in r.trend)
        if t.size:
            ax_u.plot(t, u, lw=1, color=colours.get(r.row['level'], 'k'), alpha=0.7)
    ax_u.set_xlabel('operating time [s] (time with motion, across recordings)')
    ax_u.set_ylabel('friction parameter u [-]')
    ax_u.set_title('u trends')
    ax_u.grid(alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def analyze_fleet(root: str | Path, out: str | Path, *, ratio: float | None = None,
                  scheduler: str | None = None, workers: int | None = None,
                  progress: bool = False, unit_outputs: bool = True,
                  population: bool = False, timeout: float = CONNECT_TIMEOUT,
                  plot: bool = True, **options: Any) -> list[UnitResult]:
    """Analyse every unit under ``root`` into ``out`` (which must not exist or be empty).

    Writes ``fleet.parquet``, ``fleet.csv``, ``fleet.png`` (with ``plot``; matplotlib costs
    about a second of CPU), ``fleet_run.json`` (the cluster's workers, worker memory, the
    population prior) and, with ``unit_outputs``, each unit's analysis under
    ``units/<unit>/``. ``population``: a population prior, see :func:`run_units`;
    ``timeout`` [s]: the wait for ``scheduler``.
    ``ratio`` and ``options`` (those of a ``unit.yaml``) are checked before any unit runs
    (FleetError). ``out`` is written whole or not at all: in a
    folder beside it, renamed when complete (nothing is left if the fleet fails or is
    interrupted).
    """
    root, out = Path(root), Path(out)
    units = discover_units(root)
    try:
        taken = out.exists() and (not out.is_dir() or any(out.iterdir()))
        above = next(parent for parent in out.absolute().parents if parent.exists())
    except OSError as exc:
        msg = f'cannot write --out {out}: {exc.strerror or exc}'
        raise FleetError(msg) from None
    if taken:
        raise FleetError(f'--out {out} exists and is not an empty directory')
    if not above.is_dir():
        msg = f'cannot write --out {out}: {above} is not a directory'
        raise FleetError(msg)
    try:
        fleet_options = check_options({**options, **({} if ratio is None else {'ratio': ratio})})
        check_configs(fleet_options)
    except ValueError as exc:
        raise FleetError(str(exc)) from None
    with Staged(out, FleetError, folder=True) as staged:     # empty, if there (above)
        results = _analyze_into(staged.path, root, units, fleet_options, scheduler, workers,
                                progress, unit_outputs, population, timeout, plot)
        staged.commit()
    return results


def _analyze_into(directory: Path, root: Path, units: list[Path], options: dict[str, Any],
                  scheduler: str | None, workers: int | None, progress: bool,
                  unit_outputs: bool, population: bool, timeout: float,
                  plot: bool = True) -> list[UnitResult]:
    """Run the units and write the fleet's files into ``directory`` (:func:`analyze_fleet`)."""
    bars: list[Any] = []
    cluster: dict[str, int] = {}

    def start(workers: int) -> None:    # once connected: no bar before an error
        cluster['workers'] = workers
        if progress:
            from tqdm import tqdm
            bars.append(tqdm(total=len(units), unit='unit', file=sys.stderr, desc='fleet'))

    def done() -> None:
        for bar in bars:
            bar.update()
    try:
        results = run_units(units, options, directory if unit_outputs else None, scheduler,
                            workers, on_done=done, population=population, timeout=timeout,
                            on_start=start)
    finally:
        for bar in bars:
            bar.close()
    rows = [r.row for r in results]
    try:
        write_table(rows, directory)
        if plot:
            plot_fleet(results, directory / 'fleet.png', f'gear-phm fleet {root.name}: '
                       f'{len(rows)} '
                       f'{"drives" if any("/" in row["unit"] for row in rows) else "units"}')
        (directory / 'fleet_run.json').write_text(json.dumps({
            'units': len(rows), 'failed': sum(r['level'] == 'FAILED' for r in rows),
            'workers': cluster.get('workers'),
            'peak_rss_mib_per_task': {r.row['unit']: round(r.peak_rss_mib, 1)
                                      for r in results},
            'max_peak_rss_mib': round(max(r.peak_rss_mib for r in results), 1),
            'population_prior': next((asdict(r.prior) for r in results if r.prior), None),
            'units_with_prior': [r.row['unit'] for r in results if r.prior is not None],
        }, indent=2) + '\n')
    except OSError as exc:
        msg = f'cannot write the fleet table: {exc.strerror or exc}'
        raise FleetError(msg) from None
    return results
