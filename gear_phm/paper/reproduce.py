"""Reproduce figures 3, 4 and 6 of Berri et al. (simplified vs reference efficiency model).

:func:`sample_reference_gears` draws random single-stage spur gears (the paper's "500
combinations", sampling ranges in :class:`SamplingRanges`), :func:`evaluate_samples` computes
their efficiencies with :class:`gear_phm.models.SpurGear` and the errors of the simplified lever
model, :func:`summarize` reduces them to statistics and :func:`reproduce` writes the figures,
``samples.csv`` and ``summary.json``. Plots use matplotlib's Agg canvas (no display needed).
"""
from __future__ import annotations

from collections.abc import Callable
import csv
from dataclasses import asdict, dataclass
import json
import math
from pathlib import Path
from typing import Any

from matplotlib.axes import Axes
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
import numpy as np

from gear_phm.models import (eta_aiding_from_opposing, eta_opposing_from_aiding, min_teeth,
                             SpurGear, total_squared_error)

DEFAULT_SEED = 20190415
DEFAULT_SAMPLES = 500
RATIO_RANGE = (0.1, 50.0)
FIGURE_FILES = ('fig3_surface.png', 'fig4_comparison.png', 'fig6_etot_hist.png')
CSV_COLUMNS = (
    'z1', 'z2', 'module_m', 'pressure_angle_deg', 'addendum_m', 'tooth_friction',
    'bearing_fraction_1', 'bearing_fraction_2', 'bearing_radius_1_m', 'bearing_radius_2_m',
    'ratio', 'eta_opposing', 'eta_aiding', 'eta_aiding_simplified', 'eta_opposing_simplified',
    'error_aiding', 'error_opposing', 'e_tot',
)


@dataclass(frozen=True)
class SamplingRanges:
    """Ranges of the random reference gears (uniform unless stated).

    Teeth are log-uniform and rounded to integers; samples with a wheel below the undercut
    limit ``min_teeth(pressure_angle)`` or with R = z2/z1 outside [0.1, 50] are redrawn.
    Bearing friction radii are uniform fractions of each wheel's pitch radius; fractions close
    to 1 make the gear irreversible (eta_I < 0), as the paper intends. The normal tooth force F
    of the paper cancels from both efficiencies and is not sampled. Addendum = one module.
    """

    teeth_1: tuple[float, float] = (8.0, 300.0)            # z1 [-], log-uniform
    teeth_2: tuple[float, float] = (8.0, 3000.0)           # z2 [-], log-uniform
    module: tuple[float, float] = (0.5e-3, 5e-3)           # [m]
    pressure_angle_deg: tuple[float, float] = (14.5, 30.0)  # [deg]
    tooth_friction: tuple[float, float] = (0.0, 0.5)       # Coulomb coefficient f [-]
    bearing_fraction: tuple[float, float] = (0.0, 1.0)     # rho_i / r_p,i [-]


def log_uniform(rng: np.random.Generator, bounds: tuple[float, float], n: int) -> np.ndarray:
    """Return ``n`` draws log-uniform in ``bounds``."""
    return np.exp(rng.uniform(math.log(bounds[0]), math.log(bounds[1]), n))


def sample_reference_gears(count: int, seed: int, ranges: SamplingRanges = SamplingRanges(),
                           ratio_range: tuple[float, float] = RATIO_RANGE
                           ) -> dict[str, np.ndarray]:
    """``count`` random valid gear pairs (arrays keyed like :data:`CSV_COLUMNS`), seeded.

    Pairs with R = z2 / z1 outside ``ratio_range`` are redrawn.
    """
    if count < 1:
        raise ValueError(f'count must be >= 1, got {count!r}')
    rng = np.random.default_rng(seed)

    def draw(batch: int) -> tuple[dict[str, np.ndarray], np.ndarray]:
        theta = np.deg2rad(rng.uniform(*ranges.pressure_angle_deg, batch))
        z1 = np.round(log_uniform(rng, ranges.teeth_1, batch))
        z2 = np.round(log_uniform(rng, ranges.teeth_2, batch))
        module = rng.uniform(*ranges.module, batch)
        friction = rng.uniform(*ranges.tooth_friction, batch)
        fraction_1 = rng.uniform(*ranges.bearing_fraction, batch)
        fraction_2 = rng.uniform(*ranges.bearing_fraction, batch)
        ratio = z2 / z1
        z_min = min_teeth(theta)
        ok = ((z1 >= z_min) & (z2 >= z_min)
              & (ratio >= ratio_range[0]) & (ratio <= ratio_range[1]))
        return {
            'z1': z1, 'z2': z2, 'module_m': module, 'pressure_angle_deg': np.rad2deg(theta),
            'addendum_m': module, 'tooth_friction': friction,
            'bearing_fraction_1': fraction_1, 'bearing_fraction_2': fraction_2,
            'bearing_radius_1_m': fraction_1 * module * z1 / 2,
            'bearing_radius_2_m': fraction_2 * module * z2 / 2,
        }, ok
    return rejection_sample(count, draw)


def rejection_sample(count: int,
                     draw: Callable[[int], tuple[dict[str, np.ndarray], np.ndarray]]
                     ) -> dict[str, np.ndarray]:
    """Keep the accepted rows of ``draw(batch)`` (columns, accepted mask) until ``count``."""
    kept: dict[str, list[np.ndarray]] = {}
    total = 0
    while total < count:
        columns, ok = draw(max(64, 2 * (count - total)))
        for name, values in columns.items():
            kept.setdefault(name, []).append(values[ok])
        total += int(np.count_nonzero(ok))
    return {name: np.concatenate(parts)[:count] for name, parts in kept.items()}


def gears_of(samples: dict[str, np.ndarray], with_bearings: bool = True) -> SpurGear:
    """One vectorised :class:`SpurGear` for all samples (optionally with ideal bearings)."""
    scale = 1.0 if with_bearings else 0.0
    return SpurGear(
        samples['z1'], samples['z2'], module=samples['module_m'],
        pressure_angle=np.deg2rad(samples['pressure_angle_deg']),
        addendum=samples['addendum_m'], friction=samples['tooth_friction'],
        bearing_radius_1=scale * samples['bearing_radius_1_m'],
        bearing_radius_2=scale * samples['bearing_radius_2_m'])


def evaluate_samples(samples: dict[str, np.ndarray],
                     with_bearings: bool = True) -> dict[str, np.ndarray]:
    """Compute reference efficiencies and the errors of the simplified model (eqs 5, 8, 14, 15).

    error_aiding = eta_I,ref - eta_I(eta_D,ref) (vertical), error_opposing =
    eta_D,ref - eta_D(eta_I,ref) (horizontal); NaN where the point has no image on the curve.
    """
    gear = gears_of(samples, with_bearings)
    eta_d, eta_i = (np.asarray(x, dtype=float) for x in gear.efficiencies())
    table = dict(samples)
    table.update(compare_with_lever(eta_d, eta_i, np.asarray(gear.ratio, dtype=float)))
    return table


def compare_with_lever(eta_d: np.ndarray, eta_i: np.ndarray,
                       ratio: np.ndarray) -> dict[str, np.ndarray]:
    """Compare reference efficiencies with the simplified lever model at the same R (eqs 14, 15).

    Columns ratio, eta_opposing, eta_aiding, eta_aiding_simplified, eta_opposing_simplified,
    error_aiding, error_opposing and e_tot; NaN where the point has no image on the curve or
    an efficiency is NaN (a jammed train).
    """
    defined = np.isfinite(eta_d) & np.isfinite(eta_i)      # NaN: a train that jams
    simplified_i, simplified_d, e_tot = (np.full(eta_d.shape, np.nan) for _ in range(3))
    simplified_i[defined] = eta_aiding_from_opposing(eta_d[defined], ratio[defined])
    simplified_d[defined] = eta_opposing_from_aiding(eta_i[defined], ratio[defined])
    e_tot[defined] = total_squared_error(eta_d[defined], eta_i[defined], ratio[defined])
    return {
        'ratio': ratio, 'eta_opposing': eta_d, 'eta_aiding': eta_i,
        'eta_aiding_simplified': simplified_i, 'eta_opposing_simplified': simplified_d,
        'error_aiding': eta_i - simplified_i, 'error_opposing': eta_d - simplified_d,
        'e_tot': e_tot,
    }


def quantile_stats(values: np.ndarray) -> dict[str, float]:
    """Return count, mean, min, p5, p25, median, p75, p95, max of the finite values."""
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return {'count': 0}
    quantiles = np.percentile(finite, [5, 25, 50, 75, 95])
    return {
        'count': int(finite.size), 'mean': float(finite.mean()), 'min': float(finite.min()),
        'p5': float(quantiles[0]), 'p25': float(quantiles[1]), 'median': float(quantiles[2]),
        'p75': float(quantiles[3]), 'p95': float(quantiles[4]), 'max': float(finite.max()),
    }


BEARING_FRACTION_EDGES = (0.0, 0.05, 0.1, 0.25, 0.5, 1.0)


def _by_bearing_fraction(table: dict[str, np.ndarray]) -> dict[str, dict[str, float]]:
    """Median e_tot and sample count per bin of max(rho_1 / r_p1, rho_2 / r_p2)."""
    largest = np.maximum(table['bearing_fraction_1'], table['bearing_fraction_2'])
    result = {}
    edges = BEARING_FRACTION_EDGES
    for low, high in zip(edges[:-1], edges[1:]):
        chosen = (largest >= low) & (largest < high) & np.isfinite(table['e_tot'])
        values = table['e_tot'][chosen]
        result[f'{low:g}-{high:g}'] = {
            'count': int(values.size),
            'median': float(np.median(values)) if values.size else 0.0}
    return result


def summarize(table: dict[str, np.ndarray]) -> dict[str, Any]:
    """Statistics of e_tot and of the absolute efficiency errors (all finite numbers)."""
    e_tot = table['e_tot']
    finite = np.isfinite(e_tot)
    abs_d, abs_i = np.abs(table['error_opposing']), np.abs(table['error_aiding'])
    both = np.isfinite(abs_d) & np.isfinite(abs_i)
    n = int(e_tot.size)
    return {
        'samples': n,
        'irreversible_fraction': float(np.mean(table['eta_aiding'] < 0.0)),
        'no_image_on_curve': int(n - np.count_nonzero(finite)),
        'e_tot': quantile_stats(e_tot),
        'e_tot_fraction_below_1e-2': float(np.mean(e_tot[finite] < 1e-2)),
        'e_tot_fraction_below_1e-3': float(np.mean(e_tot[finite] < 1e-3)),
        'normal_distance_median': float(math.sqrt(np.median(e_tot[finite]))),
        'abs_error_opposing': quantile_stats(abs_d),
        'abs_error_aiding': quantile_stats(abs_i),
        'fraction_both_abs_errors_below_0.1': float(np.mean(
            (abs_d[both] < 0.1) & (abs_i[both] < 0.1))),
        'fraction_min_abs_error_below_0.1': float(np.mean(
            np.minimum(abs_d[both], abs_i[both]) < 0.1)),
        **({'e_tot_median_by_max_bearing_fraction': _by_bearing_fraction(table)}
           if 'bearing_fraction_1' in table else {}),
        'ratio': quantile_stats(table['ratio']),
        'eta_opposing': quantile_stats(table['eta_opposing']),
        'eta_aiding': quantile_stats(table['eta_aiding']),
    }


def write_csv(table: dict[str, np.ndarray], path: Path,
              columns: tuple[str, ...] = CSV_COLUMNS) -> None:
    """One row per sample, ``columns`` (SI units, angles in degrees)."""
    with path.open('w', newline='') as stream:
        writer = csv.writer(stream)
        writer.writerow(columns)
        for row in zip(*(table[name] for name in columns)):
            writer.writerow([repr(float(value)) for value in row])


# ------------------------------------------------------------------------------ figures

def surface_grid(points: int = 161, ratio_range: tuple[float, float] = RATIO_RANGE
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """eta_D in [-1, 1] x log-spaced R in ``ratio_range`` -> eta_I clipped to [-1, 1].

    NaN where no friction value u >= 0 gives that eta_D (eta_D <= -1/R).
    """
    eta_d = np.linspace(-1.0, 1.0, points)
    ratio = np.geomspace(*ratio_range, points)
    grid_d, grid_r = np.meshgrid(eta_d, ratio)
    eta_i = eta_aiding_from_opposing(grid_d, grid_r)
    eta_i = np.where(grid_d > -1.0 / grid_r, np.clip(eta_i, -1.0, 1.0), np.nan)
    return grid_d, grid_r, eta_i


LEVELS = np.linspace(-1.0, 1.0, 21)
NORM = Normalize(-1.0, 1.0)
CMAP = 'viridis'
#: (eta_D, R, eta_I) on a meshgrid.
Grid = tuple[np.ndarray, np.ndarray, np.ndarray]


def _contour_panel(fig: Figure, axes: Axes, grid: Grid) -> None:
    grid_d, grid_r, eta_i = grid
    filled = axes.contourf(grid_d, grid_r, eta_i, levels=LEVELS, cmap=CMAP, norm=NORM)
    lines = axes.contour(grid_d, grid_r, eta_i, levels=[-0.5, 0.0, 0.5, 0.9], colors='k',
                         linewidths=0.7)
    axes.clabel(lines, fmt='%.1f', fontsize=8)
    axes.set_yscale('log')
    axes.set_xlim(-1.0, 1.0)
    axes.set_xlabel(r'opposing-load efficiency $\eta_D$ [-]')
    axes.set_ylabel('transmission ratio R [-]')
    axes.grid(True, which='both', alpha=0.25)
    fig.colorbar(filled, ax=axes, label=r'aiding-load efficiency $\eta_I$ [-]')


def _surface_panel(axes: Any, grid: Grid, alpha: float = 0.85) -> None:
    grid_d, grid_r, eta_i = grid
    axes.plot_surface(grid_d, np.log10(grid_r), eta_i, cmap=CMAP, norm=NORM, alpha=alpha,
                      linewidth=0, antialiased=True, rcount=60, ccount=60)
    axes.set_xlim(-1.0, 1.0)
    axes.set_zlim(-1.0, 1.0)
    axes.set_xlabel(r'$\eta_D$ [-]')
    axes.set_ylabel('R [-] (log scale)')
    axes.zaxis.set_rotate_label(False)
    axes.set_zlabel(r'$\eta_I$ [-]', rotation=90)
    axes.set_yticks([-1, 0, 1, math.log10(50)])
    axes.set_yticklabels(['0.1', '1', '10', '50'])
    axes.view_init(elev=28, azim=-55)
    axes.set_box_aspect(None, zoom=0.85)


def plot_surface(path: Path) -> None:
    """Figure 3: simplified model eta_I(eta_D, R), R in [0.1, 50]."""
    grid = surface_grid()
    fig = Figure(figsize=(13, 5.5), layout='constrained')
    _contour_panel(fig, fig.add_subplot(1, 2, 1), grid)
    _surface_panel(fig.add_subplot(1, 2, 2, projection='3d'), grid)
    fig.suptitle(r'Simplified model (corrected eq 14): $\eta_I$ over $\eta_D$ and R. '
                 r'$\eta_I < -1$ shown as $-1$; white: $\eta_D \leq -1/R$, reached by no '
                 r'friction $u \geq 0$')
    fig.savefig(path, dpi=110)


def plot_comparison(table: dict[str, np.ndarray], path: Path) -> None:
    """Figure 4: reference samples over the simplified surface.

    Also a parity plot of eta_I and e_tot against the bearing friction radius (what drives the
    disagreement).
    """
    grid = surface_grid(101)
    eta_d, eta_i, ratio = table['eta_opposing'], table['eta_aiding'], table['ratio']
    shown = (eta_d >= -1) & (eta_d <= 1) & (eta_i >= -1) & (eta_i <= 1)
    fig = Figure(figsize=(14, 11.5), layout='constrained')
    axes3d = fig.add_subplot(2, 2, 1, projection='3d')
    _surface_panel(axes3d, grid, alpha=0.45)
    axes3d.scatter(eta_d[shown], np.log10(ratio[shown]), eta_i[shown], s=12,
                   facecolors='none', edgecolors='tab:blue', depthshade=False)
    axes3d.set_title('reference samples (blue circles) over the simplified surface',
                     fontsize=10)

    map_panel(fig, fig.add_subplot(2, 2, 2), grid, table)

    parity_panel(fig, fig.add_subplot(2, 2, 3), table)

    axes = fig.add_subplot(2, 2, 4)
    largest = np.maximum(table['bearing_fraction_1'], table['bearing_fraction_2'])
    finite = np.isfinite(table['e_tot']) & (table['e_tot'] > 0)
    scatter = axes.scatter(largest[finite], table['e_tot'][finite],
                           c=table['tooth_friction'][finite], s=10, cmap='cividis')
    axes.set_yscale('log')
    axes.set_xlabel(r'largest bearing friction radius / pitch radius $\rho_i / r_{p,i}$ [-]')
    axes.set_ylabel(r'total squared error $e_{tot}$ [-] (eq 15)')
    axes.set_title('disagreement grows with bearing friction', fontsize=10)
    axes.grid(True, which='major', alpha=0.3)
    fig.colorbar(scatter, ax=axes, label='tooth friction coefficient f [-]')
    fig.suptitle(f'Reference spur-gear model vs simplified model, {eta_d.size} random gears '
                 f'({int(np.count_nonzero(shown))} with both efficiencies in [-1, 1])')
    fig.savefig(path, dpi=100)


def map_panel(fig: Figure, axes: Axes, grid: Grid, table: dict[str, np.ndarray]) -> None:
    """Draw samples (red circles) at their (eta_D, R) over the map of the simplified eta_I."""
    eta_d, eta_i, ratio = table['eta_opposing'], table['eta_aiding'], table['ratio']
    shown = (eta_d >= -1) & (eta_d <= 1) & (eta_i >= -1) & (eta_i <= 1)
    _contour_panel(fig, axes, grid)
    axes.scatter(eta_d[shown], ratio[shown], s=14, facecolors='none', edgecolors='tab:red',
                 linewidths=0.8)
    axes.set_title(r'samples (red circles) at their ($\eta_D$, R); colour: simplified '
                   r'$\eta_I$', fontsize=10)


def parity_panel(fig: Figure, axes: Axes, table: dict[str, np.ndarray],
                 ratio_range: tuple[float, float] = RATIO_RANGE,
                 reference: str = 'eq 8') -> None:
    """Plot reference eta_I against the simplified eta_I(eta_D,ref, R), coloured by log10 R."""
    eta_d = table['eta_opposing']
    simplified = table['eta_aiding_simplified']
    ok = np.isfinite(simplified)
    scatter = axes.scatter(simplified[ok], table['eta_aiding'][ok],
                           c=np.log10(table['ratio'][ok]), s=10, cmap='plasma',
                           vmin=math.log10(ratio_range[0]), vmax=math.log10(ratio_range[1]))
    axes.plot([-1, 1], [-1, 1], 'k-', linewidth=1, label='simplified = reference')
    axes.plot([-1, 1], [-0.9, 1.1], 'k:', linewidth=0.8, label=r'$\pm 0.1$')
    axes.plot([-1, 1], [-1.1, 0.9], 'k:', linewidth=0.8)
    axes.set_xlim(-1, 1)
    axes.set_ylim(-1, 1)
    axes.set_xlabel(r'simplified $\eta_I(\eta_{D,ref}, R)$ [-] (eq 14)')
    axes.set_ylabel(rf'reference $\eta_{{I,ref}}$ [-] ({reference})')
    axes.set_title(f'aiding efficiency: reference vs simplified '
                   f'({int(np.count_nonzero(ok & (simplified >= -1)))} of {eta_d.size} '
                   'in view)', fontsize=10)
    axes.grid(True, alpha=0.3)
    axes.legend(loc='upper left', fontsize=8)
    fig.colorbar(scatter, ax=axes, label=r'$\log_{10}$ R [-]')


def plot_error_histogram(table: dict[str, np.ndarray], path: Path) -> None:
    """Figure 6 (captioned "Figure 4" in the paper): distribution of e_tot, log x axis."""
    e_tot = table['e_tot']
    e_tot = e_tot[np.isfinite(e_tot)]
    positive = e_tot[e_tot > 0]
    fig = Figure(figsize=(8, 5), layout='constrained')
    axes = fig.add_subplot(1, 1, 1)
    low = math.floor(math.log10(positive.min())) if positive.size else -12
    high = math.ceil(math.log10(positive.max())) if positive.size else 0
    bins = np.logspace(low, max(high, low + 1), 4 * (max(high, low + 1) - low) + 1)
    axes.hist(positive, bins=bins.tolist(), color='tab:blue', edgecolor='white')
    axes.set_xscale('log')
    median = float(np.median(e_tot)) if e_tot.size else math.nan
    axes.axvline(median, color='tab:red', label=f'median {median:.2g}')
    axes.axvline(1e-2, color='k', linestyle='--', label='$10^{-2}$ (paper: typical)')
    axes.set_xlabel(r'total squared error $e_{tot}$ [-] (eq 15)')
    axes.set_ylabel('number of samples [-]')
    axes.set_title(f'Distribution of $e_{{tot}}$, {e_tot.size} samples with an image on '
                   'the simplified curve')
    axes.legend()
    axes.grid(True, which='major', alpha=0.3)
    fig.savefig(path, dpi=110)


def reproduce(out_dir: Path, seed: int = DEFAULT_SEED, samples: int = DEFAULT_SAMPLES,
              ranges: SamplingRanges = SamplingRanges()) -> dict[str, Any]:
    """Write the three figures, samples.csv and summary.json into ``out_dir``; return summary."""
    out_dir.mkdir(parents=True, exist_ok=True)
    drawn = sample_reference_gears(samples, seed, ranges)
    table = evaluate_samples(drawn)
    tooth_only = evaluate_samples(drawn, with_bearings=False)
    summary = summarize(table)
    summary['seed'] = seed
    summary['sampling_ranges'] = asdict(ranges)
    summary['ideal_bearings_same_samples'] = {
        key: summarize(tooth_only)[key]
        for key in ('e_tot', 'abs_error_opposing', 'abs_error_aiding',
                    'fraction_both_abs_errors_below_0.1', 'irreversible_fraction')}
    summary['large_ratio_limit'] = {
        f'eta_aiding_at_eta_opposing_0.5_R_{ratio:g}': float(eta_aiding_from_opposing(0.5, ratio))
        for ratio in (10.0, 50.0, 1e3, 1e6)}
    write_csv(table, out_dir / 'samples.csv')
    plot_surface(out_dir / FIGURE_FILES[0])
    plot_comparison(table, out_dir / FIGURE_FILES[1])
    plot_error_histogram(table, out_dir / FIGURE_FILES[2])
    (out_dir / 'summary.json').write_text(json.dumps(summary, indent=2, allow_nan=False) + '\n')
    return summary
