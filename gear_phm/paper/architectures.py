"""The paper's open question per architecture: where does the simplified lever model hold.

For each architecture of :data:`ARCHITECTURES` a seeded sampler draws random geometries over
the ranges of docs/paper-reproduction.md, the reference model of :mod:`gear_phm.models` gives
their eta_D and eta_I, and :func:`~gear_phm.paper.reproduce.compare_with_lever` the errors of
the lever model at the same R (eqs 14, 15). :func:`run_architecture` writes the figures,
``samples.csv`` and ``summary.json``; :func:`run` one architecture or several (a directory
each) and the table (``table.md``, ``table.csv``). 'spur' is the paper's reproduction
(:func:`gear_phm.paper.reproduce.reproduce`).
"""
from __future__ import annotations

from collections.abc import Callable
import csv
from dataclasses import asdict, dataclass, replace
import json
import math
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure
import numpy as np

from gear_phm.models import (BallScrew, HelicalGear, LeadScrew, PlanetaryGearSet, RollerScrew,
                             series_efficiencies, u_from_eta_aiding, u_from_eta_opposing,
                             WormGear)
from gear_phm.models.internal_gear import interference_free
from gear_phm.models.planetary import MEMBERS
from gear_phm.models.spur_gear import min_teeth
from gear_phm.paper.reproduce import (compare_with_lever, evaluate_samples, FIGURE_FILES,
                                      log_uniform, map_panel, parity_panel,
                                      plot_error_histogram, quantile_stats, rejection_sample,
                                      reproduce, sample_reference_gears, SamplingRanges,
                                      summarize, surface_grid, write_csv)

ARCHITECTURES = ('spur', 'helical', 'multistage', 'planetary', 'worm', 'screw')
#: The six planetary configurations (fixed, driving), index = the ``configuration`` column.
CONFIGURATIONS = tuple((fixed, driving) for fixed in MEMBERS for driving in MEMBERS
                       if fixed != driving)
SCREW_KINDS = ('lead', 'ball', 'roller')
LEVER_COLUMNS = ('ratio', 'eta_opposing', 'eta_aiding', 'eta_aiding_simplified',
                 'eta_opposing_simplified', 'error_aiding', 'error_opposing', 'e_tot')
TABLE_COLUMNS = ('architecture', 'samples', 'ratio_p5', 'ratio_p95', 'irreversible_fraction',
                 'no_image_on_curve', 'e_tot_median', 'e_tot_p95', 'abs_error_aiding_p95',
                 'abs_offset_median', 'abs_offset_p95')


@dataclass(frozen=True)
class ArchitectureRanges:
    """Ranges of the architectures beyond the spur's (uniform unless stated; angles in deg).

    helix_angle_deg: helical stages (the rest of each stage as :class:`SamplingRanges`).
    stages, stage_ratio, stage_bearing_fraction: the multi-stage train (each stage spur or
    helical, even odds; the rest as :class:`SamplingRanges`, bearings at most a quarter of the
    pitch radius, or the spur's bound if lower, so that trains of four stages still run).
    planetary_*: teeth log-uniform, rounded; ring = sun + 2 planet, full-depth teeth;
    configuration uniform among the six; tooth friction as :class:`SamplingRanges`.
    worm_*: starts z1 uniform integers, wheel teeth z2 uniform integers, diameter quotient
    q = d1 / m, lead angle atan(z1 / q).
    screw_*: lead / diameter log-uniform per kind; lead screws sliding with the flank angle
    of a trapezoidal thread, ball and roller screws rolling.
    """

    helix_angle_deg: tuple[float, float] = (5.0, 35.0)
    stages: tuple[int, int] = (2, 4)
    stage_ratio: tuple[float, float] = (1.0, 8.0)
    stage_bearing_fraction: tuple[float, float] = (0.0, 0.25)
    planetary_stages: tuple[int, int] = (1, 3)
    planetary_sun: tuple[float, float] = (17.0, 80.0)
    planetary_planet: tuple[float, float] = (17.0, 80.0)
    planetary_pressure_angle_deg: tuple[float, float] = (20.0, 25.0)
    worm_starts: tuple[int, int] = (1, 4)
    worm_wheel_teeth: tuple[int, int] = (20, 80)
    worm_diameter_quotient: tuple[float, float] = (6.0, 20.0)
    worm_pressure_angle_deg: tuple[float, float] = (14.5, 25.0)
    worm_friction: tuple[float, float] = (0.02, 0.12)
    screw_diameter_m: tuple[float, float] = (8e-3, 80e-3)               # log-uniform
    screw_lead_over_diameter: tuple[float, float] = (0.05, 1.0)          # log-uniform
    lead_screw_flank_angle_deg: float = 15.0
    lead_screw_friction: tuple[float, float] = (0.05, 0.25)
    rolling_contact_angle_deg: tuple[float, float] = (40.0, 50.0)
    rolling_friction: tuple[float, float] = (0.002, 0.015)


Table = dict[str, np.ndarray]
Sampler = Callable[[int, int, SamplingRanges, ArchitectureRanges], Table]


def _helical_of(drawn: Table, helix_deg: np.ndarray) -> HelicalGear:
    return HelicalGear(drawn['z1'], drawn['z2'], drawn['module_m'],
                       np.deg2rad(drawn['pressure_angle_deg']), np.deg2rad(helix_deg),
                       drawn['addendum_m'], drawn['tooth_friction'],
                       drawn['bearing_radius_1_m'], drawn['bearing_radius_2_m'])


def sample_helical(count: int, seed: int, ranges: SamplingRanges,
                   more: ArchitectureRanges) -> Table:
    """Helical stages: the spur samples of the same seed, each with a random helix angle."""
    drawn = sample_reference_gears(count, seed, ranges)
    helix = np.random.default_rng([seed, 1]).uniform(*more.helix_angle_deg, count)
    eta_d, eta_i = (np.asarray(x, dtype=float) for x in _helical_of(drawn, helix)
                    .efficiencies())
    return {**drawn, 'helix_angle_deg': helix,
            **compare_with_lever(eta_d, eta_i, drawn['z2'] / drawn['z1'])}


def sample_multistage(count: int, seed: int, ranges: SamplingRanges,
                      more: ArchitectureRanges) -> Table:
    """Trains of 2-4 stages, each spur or helical with its own geometry and friction."""
    rng = np.random.default_rng([seed, 2])
    stages = rng.integers(more.stages[0], more.stages[1] + 1, count)
    ratio = np.ones(count)
    efficiencies = []
    largest_fraction = np.zeros(count)
    friction_sum = np.zeros(count)
    for slot in range(more.stages[1]):
        drawn = sample_reference_gears(
            count, seed + 1000 * (slot + 1),
            replace(ranges, bearing_fraction=(more.stage_bearing_fraction[0], min(
                more.stage_bearing_fraction[1], ranges.bearing_fraction[1]))),
            more.stage_ratio)
        helical = rng.random(count) < 0.5
        helix = np.where(helical, rng.uniform(*more.helix_angle_deg, count), 0.0)
        eta_d, eta_i = (np.asarray(x, dtype=float) for x in _helical_of(drawn, helix)
                        .efficiencies())
        used = slot < stages
        efficiencies.append((np.where(used, eta_d, 1.0), np.where(used, eta_i, 1.0)))
        ratio = ratio * np.where(used, drawn['z2'] / drawn['z1'], 1.0)
        largest_fraction = np.where(used, np.maximum(largest_fraction, np.maximum(
            drawn['bearing_fraction_1'], drawn['bearing_fraction_2'])), largest_fraction)
        friction_sum += np.where(used, drawn['tooth_friction'], 0.0)
    eta_d, eta_i = (np.asarray(x, dtype=float) for x in series_efficiencies(efficiencies))
    return {'stages': stages.astype(float), 'max_bearing_fraction': largest_fraction,
            'mean_tooth_friction': friction_sum / stages,
            **compare_with_lever(eta_d, eta_i, ratio)}


def _planetary_stage(rng: np.random.Generator, count: int, ranges: SamplingRanges,
                     more: ArchitectureRanges) -> Table:
    """``count`` valid random planetary sets (teeth, angle, module, friction, configuration)."""
    def draw(batch: int) -> tuple[Table, np.ndarray]:
        theta = np.deg2rad(rng.uniform(*more.planetary_pressure_angle_deg, batch))
        z_sun = np.round(log_uniform(rng, more.planetary_sun, batch))
        z_planet = np.round(log_uniform(rng, more.planetary_planet, batch))
        columns = {'z_sun': z_sun, 'z_planet': z_planet, 'pressure_angle_deg': np.rad2deg(theta),
                   'module_m': rng.uniform(*ranges.module, batch),
                   'tooth_friction': rng.uniform(*ranges.tooth_friction, batch),
                   'configuration': rng.integers(0, len(CONFIGURATIONS), batch).astype(float)}
        ok = ((z_sun >= min_teeth(theta)) & (z_planet >= min_teeth(theta))
              & interference_free(z_planet, z_sun + 2 * z_planet, theta))
        return columns, ok
    return rejection_sample(count, draw)


def _planetary_efficiencies(stage: Table) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(R, eta_D, eta_I) of sampled sets, each in its own configuration."""
    ratio, eta_d, eta_i = (np.full(stage['z_sun'].shape, np.nan) for _ in range(3))
    for index, (fixed, driving) in enumerate(CONFIGURATIONS):
        chosen = stage['configuration'] == index
        if not chosen.any():
            continue
        gear = PlanetaryGearSet(
            stage['z_sun'][chosen], stage['z_planet'][chosen], module=stage['module_m'][chosen],
            pressure_angle=np.deg2rad(stage['pressure_angle_deg'][chosen]),
            friction=stage['tooth_friction'][chosen], fixed=fixed, driving=driving)
        ratio[chosen] = gear.ratio
        eta_d[chosen], eta_i[chosen] = gear.efficiencies()
    return ratio, eta_d, eta_i


def sample_planetary(count: int, seed: int, ranges: SamplingRanges,
                     more: ArchitectureRanges) -> Table:
    """Planetary trains of 1-3 simple sets, each in a random one of the six configurations."""
    rng = np.random.default_rng([seed, 3])
    stages = rng.integers(more.planetary_stages[0], more.planetary_stages[1] + 1, count)
    ratio = np.ones(count)
    efficiencies = []
    first: Table = {}
    for slot in range(more.planetary_stages[1]):
        stage = _planetary_stage(rng, count, ranges, more)
        stage_ratio, eta_d, eta_i = _planetary_efficiencies(stage)
        used = slot < stages
        efficiencies.append((np.where(used, eta_d, 1.0), np.where(used, eta_i, 1.0)))
        ratio = ratio * np.where(used, stage_ratio, 1.0)
        first = first or {
            'k_first': (stage['z_sun'] + 2.0 * stage['z_planet']) / stage['z_sun'],
            'configuration_first': stage['configuration'],
            'tooth_friction_first': stage['tooth_friction']}
    eta_d, eta_i = (np.asarray(x, dtype=float) for x in series_efficiencies(efficiencies))
    return {'stages': stages.astype(float), **first, **compare_with_lever(eta_d, eta_i, ratio)}


def sample_worm(count: int, seed: int, ranges: SamplingRanges,
                more: ArchitectureRanges) -> Table:
    """Worm sets: lead angle atan(z1 / q) from the starts and the diameter quotient."""
    rng = np.random.default_rng([seed, 4])
    starts = rng.integers(more.worm_starts[0], more.worm_starts[1] + 1, count).astype(float)
    teeth = rng.integers(more.worm_wheel_teeth[0], more.worm_wheel_teeth[1] + 1,
                         count).astype(float)
    quotient = rng.uniform(*more.worm_diameter_quotient, count)
    alpha = rng.uniform(*more.worm_pressure_angle_deg, count)
    friction = rng.uniform(*more.worm_friction, count)
    worm = WormGear(np.arctan(starts / quotient), starts, teeth, np.deg2rad(alpha), friction)
    eta_d, eta_i = (np.asarray(x, dtype=float) for x in worm.efficiencies())
    return {'starts': starts, 'wheel_teeth': teeth, 'diameter_quotient': quotient,
            'lead_angle_deg': np.rad2deg(np.arctan(starts / quotient)),
            'normal_pressure_angle_deg': alpha, 'friction': friction,
            'friction_angle_deg': np.rad2deg(np.asarray(worm.friction_angle)),
            'self_locking': np.asarray(worm.self_locking, dtype=float),
            **compare_with_lever(eta_d, eta_i, np.asarray(worm.ratio, dtype=float))}


def sample_screw(count: int, seed: int, ranges: SamplingRanges,
                 more: ArchitectureRanges) -> Table:
    """Lead, ball and roller screws (even odds); R = 2 pi / lead in rad/m."""
    rng = np.random.default_rng([seed, 5])
    kind = rng.integers(0, len(SCREW_KINDS), count)
    diameter = log_uniform(rng, more.screw_diameter_m, count)
    lead = diameter * log_uniform(rng, more.screw_lead_over_diameter, count)
    rolling_angle = rng.uniform(*more.rolling_contact_angle_deg, count)
    sliding = rng.uniform(*more.lead_screw_friction, count)
    rolling = rng.uniform(*more.rolling_friction, count)
    columns = {name: np.full(count, np.nan) for name in (
        'eta_d', 'eta_i', 'lead_angle_deg', 'friction_angle_deg', 'self_locking')}
    angle = np.where(kind == 0, more.lead_screw_flank_angle_deg, rolling_angle)
    friction = np.where(kind == 0, sliding, rolling)
    for index, model in enumerate((LeadScrew, BallScrew, RollerScrew)):
        chosen = kind == index
        if not chosen.any():
            continue
        screw = model(lead[chosen], diameter[chosen], np.deg2rad(angle[chosen]),
                      friction[chosen])
        columns['eta_d'][chosen], columns['eta_i'][chosen] = screw.efficiencies()
        columns['lead_angle_deg'][chosen] = np.rad2deg(screw.lead_angle)
        columns['friction_angle_deg'][chosen] = np.rad2deg(screw.friction_angle)
        columns['self_locking'][chosen] = screw.self_locking
    return {'kind': kind.astype(float), 'lead_m': lead, 'diameter_m': diameter,
            'flank_or_contact_angle_deg': angle, 'friction': friction,
            'lead_angle_deg': columns['lead_angle_deg'],
            'friction_angle_deg': columns['friction_angle_deg'],
            'self_locking': columns['self_locking'],
            **compare_with_lever(columns['eta_d'], columns['eta_i'], 2.0 * np.pi / lead)}


@dataclass(frozen=True)
class Architecture:
    """How one architecture is sampled and plotted (x axis and colour of the e_tot panel)."""

    name: str
    title: str
    sampler: Sampler
    key: str
    key_label: str
    colour: str
    colour_label: str
    reference: str


SAMPLED: dict[str, Architecture] = {arch.name: arch for arch in (
    Architecture('helical', 'helical stages', sample_helical, 'helix_angle_deg',
                 r'helix angle $\beta$ [deg]', 'tooth_friction', 'tooth friction f [-]',
                 'HelicalGear'),
    Architecture('multistage', '2-4 spur or helical stages in series', sample_multistage,
                 'max_bearing_fraction', r'largest bearing fraction $\rho_i / r_{p,i}$ [-]',
                 'stages', 'stages [-]', 'GearTrain'),
    Architecture('planetary', '1-3 planetary sets, random configurations', sample_planetary,
                 'ratio', 'transmission ratio R [-]', 'configuration_first',
                 'configuration of the first set (index) [-]', 'PlanetaryGearSet'),
    Architecture('worm', 'worm gears', sample_worm, 'lead_angle_deg',
                 r'lead angle $\gamma$ [deg]', 'friction_angle_deg',
                 r"friction angle $\varphi'$ [deg]", 'WormGear'),
    Architecture('screw', 'lead (sliding), ball and roller screws, R = 2 pi / lead [rad/m]',
                 sample_screw, 'lead_angle_deg', r'lead angle $\lambda$ [deg]', 'kind',
                 'kind: 0 lead, 1 ball, 2 roller [-]', 'LeadScrew / BallScrew / RollerScrew'),
)}


def _ratio_range(ratio: np.ndarray) -> tuple[float, float]:
    finite = ratio[np.isfinite(ratio) & (ratio > 0)]
    low, high = (float(finite.min()), float(finite.max())) if finite.size else (0.1, 50.0)
    return 10 ** math.floor(math.log10(low)), 10 ** math.ceil(math.log10(high) + 1e-12)


def plot_architecture(arch: Architecture, table: Table, path: Path) -> None:
    """Plot the samples on the lever map, the parity of eta_I and e_tot against the key."""
    ratio_range = _ratio_range(table['ratio'])
    fig = Figure(figsize=(20, 5.8), layout='constrained')
    map_panel(fig, fig.add_subplot(1, 3, 1), surface_grid(101, ratio_range), table)
    parity_panel(fig, fig.add_subplot(1, 3, 2), table, ratio_range, arch.reference)
    axes = fig.add_subplot(1, 3, 3)
    finite = np.isfinite(table['e_tot']) & (table['e_tot'] > 0)
    scatter = axes.scatter(table[arch.key][finite], table['e_tot'][finite],
                           c=table[arch.colour][finite], s=10, cmap='cividis')
    if arch.key == 'ratio':
        axes.set_xscale('log')
    axes.set_yscale('log')
    axes.set_xlabel(arch.key_label)
    axes.set_ylabel(r'total squared error $e_{tot}$ [-] (eq 15)')
    axes.grid(True, which='major', alpha=0.3)
    fig.colorbar(scatter, ax=axes, label=arch.colour_label)
    fig.suptitle(f'Reference model ({arch.reference}) vs simplified lever model: '
                 f'{table["e_tot"].size} random {arch.title}')
    fig.savefig(path, dpi=100)


def direction_offsets(table: Table) -> np.ndarray:
    """Offset d = u(eta_I) - u(eta_D) [-] of each sample (eq 13 both ways); NaN if undefined.

    What the estimator learns as its direction offset: 0 on the lever curve.
    """
    offset = np.full(table['ratio'].shape, np.nan)
    defined = np.isfinite(table['eta_opposing']) & np.isfinite(table['eta_aiding'])
    ratio = table['ratio'][defined]
    offset[defined] = (np.asarray(u_from_eta_aiding(table['eta_aiding'][defined], ratio))
                       - np.asarray(u_from_eta_opposing(table['eta_opposing'][defined], ratio)))
    return offset


def offset_summary(table: Table) -> dict[str, Any]:
    """Statistics of the direction offset d and of |d| (see :func:`direction_offsets`)."""
    offset = direction_offsets(table)
    finite = offset[np.isfinite(offset)]
    return {'direction_offset': quantile_stats(offset),
            'abs_direction_offset': quantile_stats(np.abs(offset)),
            'abs_direction_offset_irreversible': quantile_stats(
                np.abs(offset[table['eta_aiding'] < 0.0])),
            'direction_offset_positive_fraction': float(np.mean(finite > 0.0))
            if finite.size else 0.0}


def summarize_architecture(table: Table) -> dict[str, Any]:
    """Return :func:`summarize`'s statistics, e_tot by the sign of eta_I, the offsets."""
    summary = summarize(table)
    irreversible = table['eta_aiding'] < 0.0
    summary['e_tot_reversible'] = quantile_stats(table['e_tot'][~irreversible])
    summary['e_tot_irreversible'] = quantile_stats(table['e_tot'][irreversible])
    summary.update(offset_summary(table))
    return summary


def figure_files(name: str) -> tuple[str, ...]:
    """Figure file names of one architecture ('spur': the paper's three)."""
    if name == 'spur':
        return FIGURE_FILES
    return (f'fig4_{name}_comparison.png', f'fig6_{name}_etot_hist.png')


def run_architecture(name: str, out_dir: Path, seed: int, samples: int,
                     ranges: SamplingRanges = SamplingRanges(),
                     more: ArchitectureRanges = ArchitectureRanges()) -> dict[str, Any]:
    """Write one architecture's figures, samples.csv and summary.json; return the summary."""
    if name == 'spur':        # the paper's files as they are; the offsets for the table
        summary = reproduce(out_dir, seed=seed, samples=samples, ranges=ranges)
        return {**summary, **offset_summary(
            evaluate_samples(sample_reference_gears(samples, seed, ranges)))}
    arch = SAMPLED[name]
    out_dir.mkdir(parents=True, exist_ok=True)
    table = arch.sampler(samples, seed, ranges, more)
    summary = summarize_architecture(table)
    summary.update({'architecture': name, 'seed': seed, 'sampling_ranges': asdict(ranges),
                    'architecture_ranges': asdict(more)})
    columns = tuple(c for c in table if c not in LEVER_COLUMNS) + LEVER_COLUMNS
    write_csv(table, out_dir / 'samples.csv', columns)
    plot_architecture(arch, table, out_dir / figure_files(name)[0])
    plot_error_histogram(table, out_dir / figure_files(name)[1])
    (out_dir / 'summary.json').write_text(json.dumps(summary, indent=2, allow_nan=False) + '\n')
    return summary


def table_row(name: str, summary: dict[str, Any]) -> dict[str, float | str]:
    """One row of the per-architecture table (:data:`TABLE_COLUMNS`) from a summary."""
    return {'architecture': name, 'samples': float(summary['samples']),
            'ratio_p5': summary['ratio']['p5'], 'ratio_p95': summary['ratio']['p95'],
            'irreversible_fraction': summary['irreversible_fraction'],
            'no_image_on_curve': float(summary['no_image_on_curve']),
            'e_tot_median': summary['e_tot']['median'], 'e_tot_p95': summary['e_tot']['p95'],
            'abs_error_aiding_p95': summary['abs_error_aiding']['p95'],
            'abs_offset_median': summary['abs_direction_offset']['median'],
            'abs_offset_p95': summary['abs_direction_offset']['p95']}


def _cell(value: float | str) -> str:
    if isinstance(value, str):
        return value
    if math.isnan(value):
        return '-'
    return f'{value:.0f}' if value == round(value) and abs(value) >= 1 else f'{value:.2g}'


def write_table(rows: list[dict[str, float | str]], out_dir: Path) -> str:
    """Write table.csv and table.md into ``out_dir``; return the Markdown text."""
    with (out_dir / 'table.csv').open('w', newline='') as stream:
        writer = csv.DictWriter(stream, TABLE_COLUMNS)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: v if isinstance(v, str) else repr(v) for k, v in row.items()})
    lines = ['| ' + ' | '.join(TABLE_COLUMNS) + ' |', '|' + '---|' * len(TABLE_COLUMNS)]
    lines += ['| ' + ' | '.join(_cell(row[c]) for c in TABLE_COLUMNS) + ' |' for row in rows]
    text = '\n'.join(lines) + '\n'
    (out_dir / 'table.md').write_text(text)
    return text


def run(names: tuple[str, ...], out_dir: Path, seed: int, samples: int,
        ranges: SamplingRanges = SamplingRanges()) -> str:
    """Run ``names`` (one: into ``out_dir``; several: a subdirectory each); write the table."""
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in names:
        target = out_dir if len(names) == 1 else out_dir / name
        rows.append(table_row(name, run_architecture(name, target, seed, samples, ranges)))
    return write_table(rows, out_dir)
