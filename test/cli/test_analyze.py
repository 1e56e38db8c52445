"""gear-phm analyze on the sample bags: outputs, summary, plot, bad input."""
from __future__ import annotations

import json
import math
from pathlib import Path
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

from gear_phm import interfaces
from gear_phm.bagio import BagReader
from gear_phm.cli.main import main

REPO = Path(__file__).resolve().parents[2]

HEALTHY = REPO / 'bags' / 'healthy'


def test_analyze_healthy_bag_writes_topics_summary_and_plot(tmp_path: Path) -> None:
    out = tmp_path / 'out'
    assert main(['analyze', str(HEALTHY), '--ratio', '3.0', '--out', str(out),
                 '--no-progress']) == 0
    summary = json.loads((out / 'summary.json').read_text())
    assert abs(summary['u'] - 0.05) <= 0.001            # bag: lever u = 0.05
    assert summary['samples_seen'] == summary['messages'] > 10000
    assert summary['samples_per_second'] > 0
    assert (out / 'analysis.png').stat().st_size > 20000
    with BagReader(out) as bag:
        topics = bag.topics
        for topic in interfaces.ESTIMATOR_TOPICS:
            assert topics['/' + topic] == interfaces.VECTOR3_STAMPED_TYPE
        assert topics['/diagnostics'] == interfaces.DIAGNOSTIC_ARRAY_TYPE
        stamps = [t for _, t, _ in bag.raw_messages(['/gear_phm/friction'])]
    with BagReader(HEALTHY) as source:
        start, end = source.start_ns, source.end_ns
    assert stamps == sorted(stamps) and start <= stamps[0] and stamps[-1] <= end


def test_analyze_runs_the_diagnostics_code_levels_follow_the_wear(tmp_path: Path,
                                                                  capsys) -> None:
    """bags/wearing: eta_D falls below 0.784 then below 0.7333 (EOL): OK -> WARN -> ERROR.

    Only --eta-opposing-min is given: eta_warn derives from it and the healthy eta_D learned
    at the start (0.934, true 0.9365): 0.7333 + 0.25 (0.934 - 0.7333) = 0.784. Each crossing
    gives one transition. No process noise is given: the filter learns it (the bag wears out
    in 300 s).
    """
    out = tmp_path / 'out'
    assert main(['analyze', str(REPO / 'bags' / 'wearing'), '--ratio', '3.0', '--out',
                 str(out), '--no-progress', '--no-plot', '--eta-opposing-min', '0.7333',
                 '--warn-horizon', '0.0',
                 '--transmission-name', 'flap']) == 0
    health = json.loads((out / 'summary.json').read_text())['health']
    first = health['first_seen_ns']
    assert first['OK'] < first['WARN'] < first['ERROR'], first
    assert health['level'] == 'ERROR'
    # the result on stdout: the estimate, the level, its cause and when (bag time)
    with BagReader(REPO / 'bags' / 'wearing') as bag:
        at = (first['ERROR'] - bag.start_ns) * 1e-9
    printed = capsys.readouterr()
    assert re.fullmatch(r'u = 0\.\d{5} \+/- 0\.\d{5}, eta_D = 0\.\d{4}, eta_I = 0\.\d{4}; '
                        rf'level ERROR \(end of life, at {at:.0f} s\)\n', printed.out), printed
    assert 'messages in' in printed.err and 'u = ' not in printed.err
    with BagReader(out) as bag:
        assert bag.topics['/gear_phm/health/rul'] == interfaces.VECTOR3_STAMPED_TYPE
        assert bag.message_count('/gear_phm/health/efficiency') > 1000
        statuses = [s for _, _, m in bag.messages(['/diagnostics']) for s in m.status
                    if s.name == 'gear_phm: flap']
    assert len(statuses) >= 290                      # 1 Hz over the 300 s bag
    keys = [kv.key for kv in statuses[-1].values]
    assert keys == ['u', 'u_sigma', 'eta_opposing', 'eta_aiding', 'rul_s', 'rul_p5_s',
                    'rul_p95_s', 'power_flow', 'samples_used', 'samples_rejected',
                    'samples_missing', 'operating_time_s', 'rul_operating_s',
                    'rul_operating_p5_s', 'rul_operating_p95_s', 'utilisation',
                    'eta_healthy', 'eta_warn']
    levels = [s.level for s in statuses]
    changes = [i for i in range(1, len(levels)) if levels[i] != levels[i - 1]]
    assert [levels[i] for i in changes] == [1, 2], levels
    assert re.fullmatch(r'eta_D 0\.77\d* < 0\.78\d*', statuses[changes[0]].message)
    values = {kv.key: float(kv.value) for kv in statuses[-1].values}
    assert values['eta_healthy'] == pytest.approx(0.9365, abs=0.004)
    assert values['eta_warn'] == pytest.approx(0.7333 + 0.25 * (values['eta_healthy'] - 0.7333))
    assert 'end of life' in statuses[changes[1]].message


@pytest.mark.parametrize('trend', ['auto', 'proportional', 'linear'])
def test_analyze_fits_the_wear_law_the_trend_option_names(tmp_path: Path, trend: str) -> None:
    """bags/wearing wears as u0 exp(k t): 'auto' finds its exponential form on its own.

    The proportional law u0 exp(k t), or the exponential c + a exp(k t) with c ~ 0, the same
    curve: since the refit every 1/64 of the history (issue 23) the last fit sees the last
    bins, and the two share the Akaike weight about evenly (0.52 for the exponential).
    """
    out = tmp_path / 'out'
    assert main(['analyze', str(REPO / 'bags' / 'wearing'), '--ratio', '3.0', '--out',
                 str(out), '--no-progress', '--no-plot', '--eta-opposing-min', '0.7333',
                 '--trend', trend]) == 0
    health = json.loads((out / 'summary.json').read_text())['health']
    fitted = health['trend']
    assert fitted['model'] in (('proportional', 'exponential') if trend == 'auto' else (trend,))
    if fitted['model'] in ('proportional', 'exponential'):
        # true k: ln(0.30 / 0.05) / 300 s of elapsed time; the fit is in operating time
        utilisation = float(health['values']['utilisation'])
        assert 0.5 < utilisation < 1.0
        assert fitted['shape'] == pytest.approx(math.log(6.0) / 300.0 / utilisation, rel=0.05)


def test_overwrite_replaces_only_a_previous_analysis(tmp_path: Path) -> None:
    out = tmp_path / 'out'
    argv = ['analyze', str(HEALTHY), '--ratio', '3.0', '--out', str(out), '--no-progress',
            '--no-plot']
    assert main(argv) == 0
    assert main(argv) == 2                                   # exists: refused
    assert main(argv + ['--overwrite']) == 0
    other = tmp_path / 'other'
    other.mkdir()
    (other / 'precious.txt').write_text('keep')
    assert main(argv[:5] + [str(other), '--no-progress', '--overwrite']) == 2
    assert (other / 'precious.txt').read_text() == 'keep'


@pytest.mark.parametrize('argv, message', [
    (['--ratio', '-1', '--out', 'X'], 'ratio must be in'),
    (['--ratio', '3', '--out', 'X', '--param', 'window=abc'], 'window needs a number'),
    (['--ratio', '3', '--out', 'X', '--param', 'speed=1'], 'unknown estimator parameter'),
    (['--ratio', '3', '--out', 'X', '--topic', 'nope'], "no topic 'nope'"),
    (['--ratio', '3', '--out', 'X', '--motor-joint', 'arm'], 'no message of topic'),
    # a period of 0 ns made the /diagnostics ticks an endless loop that filled the memory
    (['--ratio', '3', '--out', 'X', '--diagnostics-rate', '1e12'],
     'diagnostics_rate must be in [0.01, 1000] Hz'),
    (['--ratio', '3', '--out', 'X', '--diagnostics-rate', 'nan'],
     'diagnostics_rate must be in [0.01, 1000] Hz'),
])
def test_bad_input_one_line_error_exit_2(tmp_path: Path, argv: list[str],
                                         message: str) -> None:
    argv = [str(tmp_path / a) if a == 'X' else a for a in argv]
    result = subprocess.run([str(Path(sys.executable).parent / 'gear-phm'), 'analyze',
                             str(HEALTHY), '--no-progress', '--no-plot'] + argv,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('gear-phm analyze: error:'), result.stderr
    assert message in lines[0]


def test_overwrite_replaces_only_an_earlier_analysis(tmp_path: Path) -> None:
    """--overwrite removed the whole --out: the bag analysed and a user's notes with it."""
    work = tmp_path / 'work'
    shutil.copytree(HEALTHY, work / 'bag')
    (work / 'summary.json').write_text('{}')
    (work / 'notes.txt').write_text('mine')
    result = subprocess.run([str(Path(sys.executable).parent / 'gear-phm'), 'analyze',
                             str(work / 'bag'), '--ratio', '3', '--out', str(work),
                             '--overwrite', '--no-plot', '--no-progress'],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [
        f'gear-phm analyze: error: --out {work} holds the bag {work / "bag"} being analysed: '
        'write the analysis elsewhere']
    assert main(['analyze', str(HEALTHY), '--ratio', '3', '--out', str(work), '--overwrite',
                 '--no-plot', '--no-progress']) == 2     # notes.txt and bag/: not an analysis
    assert (work / 'notes.txt').read_text() == 'mine'
    assert (work / 'bag' / 'metadata.yaml').is_file()
    earlier = tmp_path / 'earlier'
    assert main(['analyze', str(HEALTHY), '--ratio', '3', '--out', str(earlier), '--no-plot',
                 '--no-progress']) == 0
    assert main(['analyze', str(HEALTHY), '--ratio', '3', '--out', str(earlier), '--no-plot',
                 '--no-progress', '--overwrite']) == 0    # its own files: replaced


def test_out_that_cannot_be_written_is_one_line(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / 'file').write_text('x')
    (tmp_path / 'empty').mkdir()
    (tmp_path / 'link').symlink_to(tmp_path / 'empty')
    for out, message in ((tmp_path / 'file' / 'out', 'cannot write --out'),
                         (tmp_path / 'link', 'is a symbolic link')):
        assert main(['analyze', str(HEALTHY), '--ratio', '3', '--out', str(out), '--no-plot',
                     '--no-progress']) == 2
        lines = capsys.readouterr().err.strip().splitlines()
        assert len(lines) == 1 and message in lines[0], lines
    assert sorted(p.name for p in tmp_path.iterdir()) == ['empty', 'file', 'link']


def test_missing_bag_and_existing_out(tmp_path: Path) -> None:
    (tmp_path / 'full').mkdir()
    (tmp_path / 'full' / 'x').write_text('x')
    assert main(['analyze', str(tmp_path / 'none'), '--ratio', '3', '--out',
                 str(tmp_path / 'o')]) == 2
    assert main(['analyze', str(HEALTHY), '--ratio', '3', '--out',
                 str(tmp_path / 'full')]) == 2


def test_diagnostics_report_the_state_at_their_own_bag_time(tmp_path: Path) -> None:
    """Each estimator /diagnostics message counts exactly the JointState logged before it.

    Ticks come every second of bag time, then one at the last message, whatever batches the
    bag was read in: no state from later samples leaks into it.
    """
    out = tmp_path / 'out'
    assert main(['analyze', str(HEALTHY), '--ratio', '3.0', '--out', str(out),
                 '--no-progress', '--no-plot']) == 0
    with BagReader(HEALTHY) as bag:
        logged = np.array([t for _, t, _ in bag.raw_messages(['/joint_states'])])
    with BagReader(out) as bag:
        reports = [(t, {kv.key: kv.value for kv in s.values})
                   for _, t, m in bag.messages(['/diagnostics']) for s in m.status
                   if s.name == 'gear_phm estimator: estimator']
    stamps = np.array([t for t, _ in reports])
    assert np.all(np.diff(stamps[:-1]) == 10**9)                     # 1 Hz in bag time
    assert stamps[0] == logged[0] + 10**9 and stamps[-1] == logged[-1]
    received = [int(values['messages_received']) for _, values in reports]
    expected = [int(np.searchsorted(logged, t)) for t in stamps[:-1]] + [logged.size]
    assert received == expected
    used = [int(values['samples_used']) for _, values in reports]
    assert used == sorted(used) and 0 < used[0] < used[-1]


def test_a_healthy_gearbox_stays_ok_from_start_to_end(tmp_path: Path) -> None:
    """bags/healthy (constant u = 0.05) with defaults only: never WARN, RUL inf throughout.

    The filter settling from its prior wanders by about 2 of its sigmas in the first seconds;
    that is not growth (prognostics/predictor.py, detection).
    """
    out = tmp_path / 'out'
    assert main(['analyze', str(REPO / 'bags' / 'healthy'), '--ratio', '3.0', '--out',
                 str(out), '--no-progress', '--no-plot']) == 0
    health = json.loads((out / 'summary.json').read_text())['health']
    assert set(health['first_seen_ns']) == {'OK'}, health
    with BagReader(out) as bag:
        rul = [m.vector for _, _, m in bag.messages(['/gear_phm/health/rul'])]
    assert len(rul) > 1000 and all(math.isinf(v.x) and math.isinf(v.y) for v in rul)


def test_two_recordings_a_week_apart_run_on_operating_time(tmp_path: Path) -> None:
    """Issue 13 through the entry points: two recordings, back to back and a week apart.

    Two 60 s recordings of linear wear (1e-3 1/s of operation). The filter and the RUL run on
    operating time, so u and the operating RUL agree; rul_s is rul_operating_s over the
    utilisation (operating time / elapsed stamp time, about 1e-4 across the week).
    """
    summaries = {}
    for name, gap in (('plain', '0'), ('week', str(7 * 86400))):
        fleet = tmp_path / name
        assert main(['simulate', '--fleet', '1', '--recordings', '2', '--duration', '60',
                     '--gap', gap, '--unit-spread', '0', '--wear', 'linear',
                     '--friction-initial', '0.05', '--wear-rate', '1e-3', '--start-time',
                     '1700000000', '--out', str(fleet)]) == 0
        bags = sorted(str(p) for p in (fleet / 'unit_00').glob('rec_*'))
        out = tmp_path / f'{name}-analysis'
        assert main(['analyze', *bags, '--ratio', '3.0', '--out', str(out), '--no-progress',
                     '--no-plot']) == 0
        summaries[name] = json.loads((out / 'summary.json').read_text())
        with BagReader(out) as bag:
            assert bag.topics['/' + interfaces.OPERATING_TIME] == \
                interfaces.VECTOR3_STAMPED_TYPE
            statuses = [s for _, _, m in bag.messages(['/diagnostics']) for s in m.status
                        if s.name == 'gear_phm: gearbox']
        assert [kv.key for kv in statuses[-1].values] == list(interfaces.STATUS_KEYS)
    plain, week = summaries['plain'], summaries['week']
    values = {name: {k: float(v) for k, v in s['health']['values'].items()}
              for name, s in summaries.items()}
    # operating time: the moving part of the 120 s (dwells and the week do not count)
    assert 80.0 < week['operating_time_s'] < 120.0
    assert week['operating_time_s'] == pytest.approx(plain['operating_time_s'], abs=0.02)
    assert values['week']['operating_time_s'] == pytest.approx(week['operating_time_s'],
                                                               abs=0.2)
    # no jump across the week: u as without the gap, and near the plant's 0.05 + 1e-3 * 120
    assert abs(week['u'] - plain['u']) <= plain['sigma_u']
    assert week['u'] == pytest.approx(plain['u'], abs=1e-9)          # measured: 1e-13
    assert abs(week['u'] - 0.17) <= 0.01
    # the RUL in operating time (u_eol 0.6 at 600 s of operation) as without the gap ...
    rul_op = values['week']['rul_operating_s']
    assert 300.0 < rul_op < 600.0
    assert rul_op == pytest.approx(values['plain']['rul_operating_s'], rel=1e-3)
    # ... and in elapsed time divided by the utilisation: ~100 s / (120 s + one week)
    utilisation = values['week']['utilisation']
    assert utilisation == pytest.approx(values['week']['operating_time_s']
                                        / (120.0 + 7 * 86400.0), rel=0.05)
    assert values['week']['rul_s'] == pytest.approx(rul_op / utilisation, rel=1e-9)
    assert values['plain']['utilisation'] > 0.7


def _rul_bands(out: Path) -> list[tuple[float, float, float]]:
    """(median, p5, p95) of the RUL in operating time of each /diagnostics gearbox status."""
    with BagReader(out) as bag:
        rows = [{kv.key: float(kv.value) for kv in s.values}
                for _, _, m in bag.messages(['/diagnostics']) for s in m.status
                if s.name == 'gear_phm: gearbox']
    return [(r['rul_operating_s'], r['rul_operating_p5_s'], r['rul_operating_p95_s'])
            for r in rows]


def test_eta_accuracy_widens_the_rul_band_not_its_median(tmp_path: Path) -> None:
    """--eta-accuracy (a calibration uncertainty that does not average out) widens the band.

    bags/wearing, u_eol 0.25 (eta_D 0.7333, R 3): du/deta_D = -1.18, so 0.02 is u +/- 0.0235
    at end of life, over du/dt ~8e-4 /s near it: a 90 % band +/- 1.645 x 28 s. The law is
    given (``--trend proportional``, the bag's u0 exp(k t)), so that the band holds no
    model-form uncertainty (calibration.MODEL_FORM_SIGMA) and the systematic term shows alone.
    """
    bands = {}
    for accuracy in ('0.0', '0.02'):
        out = tmp_path / accuracy
        assert main(['analyze', str(REPO / 'bags' / 'wearing'), '--ratio', '3.0', '--out',
                     str(out), '--no-progress', '--no-plot', '--eta-opposing-min', '0.7333',
                     '--trend', 'proportional', '--eta-accuracy', accuracy]) == 0
        bands[accuracy] = _rul_bands(out)
    late = [i for i, (median, _, _) in enumerate(bands['0.0']) if 10.0 < median < 60.0]
    assert len(late) > 20
    for i in late:
        (m0, lo0, hi0), (m1, lo1, hi1) = bands['0.0'][i], bands['0.02'][i]
        # the upper half (the lower one is cut at a RUL of 0 s)
        assert hi0 - m0 < 5.0 and 20.0 < hi1 - m1 < 75.0, (bands['0.0'][i], bands['0.02'][i])
        assert lo1 <= lo0
        assert m1 == pytest.approx(m0, abs=3.0)
    assert main(['analyze', str(REPO / 'bags' / 'wearing'), '--ratio', '3.0', '--out',
                 str(tmp_path / 'bad'), '--eta-accuracy', '-0.1']) == 2
    assert not (tmp_path / 'bad').exists()


def _true_eol(bag: Path, eta_opposing_min: float) -> float:
    """First stamp [s] at which the simulated bag's true eta_D is at or below the threshold."""
    with BagReader(bag) as truth:
        rows = [(m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec, m.vector.x)
                for _, _, m in truth.messages(['/' + interfaces.TRUTH_EFFICIENCY])]
    return next(t for t, eta_d in rows if eta_d <= eta_opposing_min)


def test_spur_gear_end_of_life_follows_the_opposing_efficiency(tmp_path: Path) -> None:
    """An unseen plant: a spur stage (R 30, bearing friction) whose tooth friction wears.

    Its opposing and aiding windows disagree (the lever model is not the plant), and the
    filter's u lags the accelerating wear. Measured: the true eta_D reaches 0.8718 at 820 s;
    ERROR came at 992 s before this session, 964 s with end of life on the opposing
    windows' reading, 889 s with the RUL's 95 % bound as well.
    """
    bag, out = tmp_path / 'bag', tmp_path / 'out'
    assert main(['simulate', '--out', str(bag), '--plant', 'spur', '--ratio', '30',
                 '--duration', '1000', '--rate', '100', '--seed', '4', '--wear', 'power',
                 '--wear-exponent', '3', '--friction-initial', '0.05', '--wear-rate', '2.5e-10',
                 '--bearing-radius-1', '0.001', '--bearing-radius-2', '0.003']) == 0
    assert main(['analyze', str(bag), '--ratio', '30', '--eta-opposing-min', '0.8718',
                 '--out', str(out), '--no-progress', '--no-plot']) == 0
    true_eol = _true_eol(bag, 0.8718)
    assert true_eol == pytest.approx(820.0, abs=1.0)
    health = json.loads((out / 'summary.json').read_text())['health']
    error = health['first_seen_ns']['ERROR'] * 1e-9
    assert true_eol < error < true_eol + 90.0, error
    with BagReader(out) as bag_out:
        levels = [s.level for _, _, m in bag_out.messages(['/diagnostics']) for s in m.status
                  if s.name == 'gear_phm: gearbox']
    changes = [b for a, b in zip(levels, levels[1:]) if a != b]
    assert changes == [1, 2], changes                 # eta_D < eta_warn from the start


def test_rul_band_holds_curved_wear_the_median_cannot_yet_see(tmp_path: Path) -> None:
    """Spur plant, tooth friction growing exponentially over a constant bearing friction.

    u = c + a exp(k t): for half the life the curvature is not significant, so the line and
    the proportional law hold the median (+208 % at 0.4 of the life). The band's lower bound
    also counts the offset exponential that the data cannot exclude (predictor module docstring).
    Measured: the band held the true RUL at 68 % of the times from 0.25 of the life before,
    93 % after. Since the wear regime's change point (issue 23): 77 %. The flat start of
    c + a exp(k t) reads as a plateau and a change point, and the offset laws from there see
    less curvature (without the change point, 93 %; bound 0.85 -> 0.75; the random-life
    ensemble's band went 39 -> 83 %, docs/prognostics.md).
    """
    bag, out = tmp_path / 'bag', tmp_path / 'out'
    assert main(['simulate', '--out', str(bag), '--plant', 'spur', '--ratio', '30',
                 '--duration', '1000', '--rate', '100', '--seed', '5', '--wear', 'exponential',
                 '--friction-initial', '0.05', '--friction-final', '0.4',
                 '--bearing-radius-1', '0.001', '--bearing-radius-2', '0.003',
                 '--truth-every', '10']) == 0
    assert main(['analyze', str(bag), '--ratio', '30', '--eta-opposing-min', '0.8616',
                 '--out', str(out), '--no-progress', '--no-plot']) == 0
    true_eol = _true_eol(bag, 0.8616)
    assert true_eol == pytest.approx(820.0, abs=2.0)
    csv = tmp_path / 'eol.csv'
    csv.write_text(f'time,true_eol\n0,{true_eol!r}\n')
    scored = tmp_path / 'evaluation.json'
    assert main(['evaluate', str(out), '--truth', str(csv), '--ratio', '30',
                 '--eta-opposing-min', '0.8616', '--output', str(scored)]) == 0
    result = json.loads(scored.read_text())
    assert result['band_coverage']['predictions'] > 500
    assert result['band_coverage']['share'] >= 0.75, result['band_coverage']


def test_the_options_default_to_the_nodes_and_out_is_required() -> None:
    import argparse

    from gear_phm.cli.analyze import add_arguments
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    args = parser.parse_args(['a', 'b', '--out', 'o', '--param', 'window=2', '--param', 'x=1'])
    assert (args.bag, args.out, args.param) == (['a', 'b'], 'o', ['window=2', 'x=1'])
    assert (args.ratio, args.transmissions, args.jobs, args.overwrite, args.no_plot) == (
        None, None, 0, False, False)
    assert (args.motor_joint, args.load_joint, args.topic) == ('motor', 'load', 'joint_states')
    with pytest.raises(SystemExit):
        parser.parse_args(['a'])                        # no --out
