"""gear-phm evaluate on recordings written with the lead's rosbag2 MCAP writer."""
from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np
import pytest

from gear_phm.bagio import Rosbag2McapWriter
from gear_phm.cli.main import main
from gear_phm.interfaces import HEALTH_EFFICIENCY, HEALTH_RUL, TRUTH_FRICTION, Vector3Out
from gear_phm.prognostics import end_of_life_u, HealthConfig
from gear_phm.simulation.lives import LIFE_FILE


def _write(directory: Path, topic: str, rows) -> None:
    with Rosbag2McapWriter(directory, compression=None) as writer:
        for t, x, y, z in rows:
            writer.write_output(Vector3Out(topic, int(round(t * 1e9)), x, y, z))


@pytest.fixture()
def bags(tmp_path: Path) -> tuple[Path, Path]:
    t = np.arange(0.0, 1000.0, 10.0)
    true_u = 0.05 + 0.55 * t / 600.0                     # reaches u_eol 0.6 at t = 600 s
    _write(tmp_path / 'truth', TRUTH_FRICTION, [(ti, ui, ui, 0.0) for ti, ui in zip(t, true_u)])
    ruls = 1.1 * (600.0 - t[t < 600.0])                  # 10 % too long: inside alpha 0.2
    _write(tmp_path / 'run' / 'bag', HEALTH_RUL,
           [(ti, r, 0.8 * r, 1.2 * r) for ti, r in zip(t, ruls)])
    return tmp_path / 'run', tmp_path / 'truth'


def test_evaluate_against_truth_bag(bags, capsys) -> None:
    run, truth = bags
    assert main(['evaluate', str(run), '--truth', str(truth)]) == 0
    result = json.loads((run / 'bag' / 'evaluation.json').read_text())
    assert result['t_eol_s'] == 600.0 and result['u_eol'] == pytest.approx(0.6)
    assert [c['passed'] for c in result['alpha_lambda']] == [True, True, True]
    assert result['relative_accuracy']['0.5'] == pytest.approx(0.9)
    # |0.1 (600 - t)| <= 0.2 * 600 everywhere: PH = whole span
    assert result['prognostic_horizon_s'] == 600.0
    assert 'PASS' in capsys.readouterr().out


def test_evaluate_csv_truth_and_stricter_eol(bags, tmp_path: Path) -> None:
    run, _ = bags
    csv = tmp_path / 'truth.csv'
    csv.write_text('time,true_eol\n0,500\n100,480\n')
    out = tmp_path / 'm.json'
    assert main(['evaluate', str(run), '--truth', str(csv), '--output', str(out)]) == 0
    result = json.loads(out.read_text())
    assert result['t_eol_s'] == 480.0
    assert not result['alpha_lambda'][2]['passed']        # 1.1 (600 - t) vs 480 - t


def test_evaluate_with_only_eta_opposing_min(bags) -> None:
    """eta_opposing_min 0.7 alone (above the old fixed eta_warn 0.6): u_eol 0.29 at 262 s."""
    run, truth = bags
    assert main(['evaluate', str(run), '--truth', str(truth), '--eta-opposing-min', '0.7']) != 2
    result = json.loads((run / 'bag' / 'evaluation.json').read_text())
    assert result['u_eol'] == pytest.approx(0.9 / 3.1)         # eta_D = 0.7 at R = 3
    assert result['t_eol_s'] == 270.0                           # first truth stamp past it


def test_evaluate_errors_are_one_line(bags, tmp_path: Path, capsys) -> None:
    run, truth = bags
    assert main(['evaluate', str(truth), '--truth', str(truth)]) == 2
    assert 'no bag with topic gear_phm/health/rul' in capsys.readouterr().err
    assert main(['evaluate', str(run), '--truth', str(truth), '--u-max', '0.0',
                 '--eta-opposing-min', '0.1', '--eta-warn', '0.2',
                 '--no-must-back-drive']) == 2
    assert 'never reaches u_eol' in capsys.readouterr().err
    assert main(['evaluate', str(run), '--truth', str(truth), '--eta-warn', '0.4']) == 2
    err = capsys.readouterr().err.strip()
    assert err.count('\n') == 0 and 'eta_warn must be > eta_opposing_min' in err


def _run_with_levels(directory: Path, error_at: float) -> None:
    """RUL inf before 100 s, then 10 % long; band tight (misses) before 300 s; levels."""
    t = np.arange(0.0, 700.0, 10.0)
    rows, states = [], []
    for ti in t:
        r = math.inf if ti < 100.0 else 1.1 * max(600.0 - ti, 0.0)
        low = 0.8 if ti >= 300.0 else 0.95          # true RUL = r / 1.1 = 0.909 r
        rows.append((ti, r, low * r, 1.2 * r))
        level = 0 if ti < 200.0 else (1 if ti < error_at else 2)
        states.append((ti, 0.7, 0.6, float(level)))
    with Rosbag2McapWriter(directory, compression=None) as writer:
        for ti, x, y, z in rows:
            writer.write_output(Vector3Out(HEALTH_RUL, int(round(ti * 1e9)), x, y, z))
        for ti, x, y, z in states:
            writer.write_output(Vector3Out(HEALTH_EFFICIENCY, int(round(ti * 1e9)), x, y, z))


@pytest.mark.parametrize('error_at', [550.0, 610.0])
def test_evaluate_scores_finiteness_band_and_level_transitions(bags, tmp_path: Path, capsys,
                                                               error_at: float) -> None:
    """The acceptance measures of docs/prognostics.md, computed by the CLI a user runs."""
    _, truth = bags
    run = tmp_path / f'levels_{error_at:.0f}'
    _run_with_levels(run, error_at)
    out = tmp_path / f'm_{error_at:.0f}.json'
    assert main(['evaluate', str(run), '--truth', str(truth), '--output', str(out)]) == 0
    result = json.loads(out.read_text())
    # last inf at 90 s, the next prediction at 100 s: 100 / 600 of the life
    assert result['rul_finite_from'] == pytest.approx(100.0 / 600.0)
    # from lambda 0.25 (150 s) to 590 s: 45 predictions, the band holds from 300 s on (30)
    assert result['band_coverage'] == {'from_lambda': 0.25, 'share': pytest.approx(30 / 45),
                                       'predictions': 45}
    steps = [(c['from'], c['to'], c['t']) for c in result['level_transitions']]
    assert steps == [('OK', 'WARN', 200.0), ('WARN', 'ERROR', error_at)]
    assert result['level_transitions'][1]['lam'] == pytest.approx(error_at / 600.0)
    assert result['error_before_eol'] is (error_at < 600.0)
    text = capsys.readouterr().out
    assert 'RUL finite from lambda 0.167\n' in text             # rounded to 3 digits
    assert 'band holds the true RUL at 66.7 % of 45 predictions' in text
    assert f'ERROR before the true end of life: {"YES" if error_at < 600.0 else "no"}' in text
    # --band-from moves the counted span: from 0.5 (300 s) every band holds
    assert main(['evaluate', str(run), '--truth', str(truth), '--output', str(out),
                 '--band-from', '0.5']) == 0
    assert json.loads(out.read_text())['band_coverage']['share'] == 1.0


def test_evaluate_without_levels_and_never_finite(bags, tmp_path: Path) -> None:
    """A run without levels has no level keys; an RUL inf to the end is finite from 'inf'.

    Its band never holds.
    """
    _, truth = bags
    run = tmp_path / 'never'
    t = np.arange(0.0, 600.0, 10.0)
    _write(run, HEALTH_RUL, [(ti, math.inf, math.inf, math.inf) for ti in t])
    out = tmp_path / 'never.json'
    assert main(['evaluate', str(run), '--truth', str(truth), '--output', str(out)]) == 0
    result = json.loads(out.read_text())
    assert result['rul_finite_from'] == 'inf'
    assert result['band_coverage']['share'] == 0.0
    assert 'level_transitions' not in result and 'error_before_eol' not in result


def _life(truth: Path, onset: float | None, end_of_life: float | None, **extra) -> None:
    """Write a life.json as `simulate --random-life` does, beside the truth bag."""
    config = HealthConfig(ratio=3.0, eta_opposing_min=0.5)
    u_eol, _ = end_of_life_u(config.ratio, config.eta_opposing_min, config.must_back_drive,
                             config.u_max)
    life = {'seed': 1, 'family': 'linear', 'healthy': end_of_life is None, 'ratio': 3.0,
            'eta_opposing_min': 0.5, 'u_eol': u_eol, 'onset_s': onset,
            'end_of_life_s': end_of_life, **extra}
    (truth / LIFE_FILE).write_text(json.dumps(life))


def test_evaluate_reads_the_life_beside_the_truth(bags, tmp_path: Path, capsys) -> None:
    """life.json: t_P = onset, its end of life; the issue-23 scores; options still win."""
    run, truth = bags
    _life(truth, onset=100.0, end_of_life=605.0)
    out = tmp_path / 'life.json'
    assert main(['evaluate', str(run), '--truth', str(truth), '--output', str(out)]) == 0
    result = json.loads(out.read_text())
    assert result['t_start_s'] == 100.0 and result['t_eol_s'] == 605.0
    score = result['acceptance']
    assert score['t_start_s'] == 100.0
    # lambda 0.5: t = 352.5, latest prediction at 350 s: 1.1 * 250 = 275 vs true 252.5
    checks = [(c['lam'], c['passed']) for c in score['alpha_lambda']]
    assert checks == [(0.5, True), (0.75, True), (0.9, True)]
    assert score['alpha_lambda'][0]['predicted_rul'] == pytest.approx(275.0)
    assert score['alpha_lambda'][0]['true_rul'] == pytest.approx(252.5)
    # lambda 0.9: t = 554.5, prediction at 550 s: 55 vs true 50.5
    assert score['alpha_lambda'][2]['predicted_rul'] == pytest.approx(55.0)
    # from lambda 0.25 (226.25 s) to 590 s: 37 predictions; p95 = 1.32 (600 - t) holds
    # 605 - t up to t = 590 (15 <= 13.2 fails): 584.8 -> t <= 580 holds
    assert score['band'] == {'from_lambda': 0.25, 'held': 36, 'predictions': 37}
    # p5 = 0.88 (600 - t) <= 605 - t always: from lambda 0.5 (352.5 s): 360..590 = 24
    assert score['not_optimistic'] == {'from_lambda': 0.5, 'held': 24, 'predictions': 24}
    assert score['finite'] == {'by_lambda': 0.25, 'finite_from': 0.0, 'passed': True}
    assert 'levels' not in score
    assert 'band holds 36 of 37 from lambda 0.25' in capsys.readouterr().out
    # an explicit --eta-opposing-min wins: u_eol 0.29 from the truth bag at 270 s
    assert main(['evaluate', str(run), '--truth', str(truth), '--output', str(out),
                 '--eta-opposing-min', '0.7']) == 0
    assert json.loads(out.read_text())['t_eol_s'] == 270.0
    # --no-life: the truth bag's end of life and the first prediction as t_P, no scores
    assert main(['evaluate', str(run), '--truth', str(truth), '--output', str(out),
                 '--no-life']) == 0
    result = json.loads(out.read_text())
    assert (result['t_start_s'], result['t_eol_s']) == (0.0, 600.0)
    assert 'acceptance' not in result


@pytest.mark.parametrize('onset, error_at, passed, early', [
    (100.0, 610.0, True, False),      # OK > WARN at 200 s, WARN > ERROR after the end of life
    (100.0, 550.0, False, False),     # ERROR before the end of life
    (250.0, 610.0, False, True),      # WARN at 200 s, before the onset
])
def test_evaluate_scores_a_life_s_levels(bags, tmp_path: Path, onset: float, error_at: float,
                                         passed: bool, early: bool) -> None:
    _, truth = bags
    _life(truth, onset=onset, end_of_life=600.0)
    run = tmp_path / 'levels'
    _run_with_levels(run, error_at)
    out = tmp_path / 'm.json'
    assert main(['evaluate', str(run), '--truth', str(truth), '--output', str(out)]) == 0
    levels = json.loads(out.read_text())['acceptance']['levels']
    assert levels == {'sequence': ['OK>WARN', 'WARN>ERROR'], 'ok_to_warn': 1,
                      'warn_to_error': 1, 'warn_before_onset': early,
                      'error_before_eol': error_at < 600.0, 'passed': passed}


@pytest.mark.parametrize('finite_at, level, passed', [
    (None, 0.0, True), (500.0, 0.0, False), (None, 1.0, False)])
def test_evaluate_scores_a_healthy_life(tmp_path: Path, capsys, finite_at: float | None,
                                        level: float, passed: bool) -> None:
    """A healthy life passes only with RUL inf and level OK at every status."""
    truth, run = tmp_path / 'truth', tmp_path / 'run'
    t = np.arange(0.0, 1000.0, 10.0)
    _write(truth, TRUTH_FRICTION, [(ti, 0.05, 0.05, 0.0) for ti in t])
    _life(truth, onset=None, end_of_life=None)
    with Rosbag2McapWriter(run, compression=None) as writer:
        for ti in t:
            rul = 100.0 if ti == finite_at else math.inf
            writer.write_output(Vector3Out(HEALTH_RUL, int(round(ti * 1e9)), rul, rul, rul))
            state = level if ti >= 700.0 else 0.0
            writer.write_output(Vector3Out(HEALTH_EFFICIENCY, int(round(ti * 1e9)), 0.9, 0.9,
                                           state))
    out = tmp_path / 'h.json'
    assert main(['evaluate', str(run), '--truth', str(truth), '--output', str(out)]) == 0
    result = json.loads(out.read_text())
    assert result['healthy'] is True
    assert result['acceptance']['healthy'] == {
        'predictions': 100, 'finite': 0 if finite_at is None else 1,
        'finite_share': 0.0 if finite_at is None else 0.01,
        'levels_seen': ['OK'] if level == 0.0 else ['OK', 'WARN'], 'passed': passed}
    assert ('PASS' if passed else 'FAIL') in capsys.readouterr().out
    # without life.json a truth that never reaches u_eol is an error, as before
    assert main(['evaluate', str(run), '--truth', str(truth), '--no-life']) == 2


def test_evaluate_rejects_a_broken_life_file(bags, capsys) -> None:
    run, truth = bags
    (truth / LIFE_FILE).write_text('{"ratio": 3.0}')
    assert main(['evaluate', str(run), '--truth', str(truth)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count('\n') == 0 and 'missing eta_opposing_min, u_eol' in err


# --- bad input: outputs, time bases, truth CSVs, option ranges ------------------------------

def _error(capsys) -> str:
    """Return the one stderr line of a failed command."""
    captured = capsys.readouterr()
    [line] = captured.err.splitlines()
    assert line.startswith('gear-phm evaluate: error: ') and 'Traceback' not in captured.err
    return line


def test_evaluate_refuses_an_output_that_is_an_input(bags, tmp_path: Path, capsys) -> None:
    """--output naming a truth or run file, or a file in the truth bag: exit 2, input kept."""
    run, truth = bags
    csv = tmp_path / 'truth.csv'
    csv.write_text('time,true_eol\n0,500\n')
    [truth_mcap] = truth.glob('*.mcap')
    [run_mcap] = (run / 'bag').glob('*.mcap')
    link = tmp_path / 'link.mcap'
    os.link(truth_mcap, link)
    before = {p: p.read_bytes() for p in (truth_mcap, run_mcap, csv, truth / 'metadata.yaml')}
    cases = [(truth, truth_mcap), (truth, truth / 'metadata.yaml'), (truth, truth / 'new.json'),
             (truth, link), (truth, run_mcap), (truth, run / 'bag' / 'metadata.yaml'),
             (csv, csv)]
    for source, output in cases:
        assert main(['evaluate', str(run), '--truth', str(source), '--output',
                     str(output)]) == 2, output
        assert 'would overwrite or write into the input' in _error(capsys)
    assert {p: p.read_bytes() for p in before} == before
    assert not (truth / 'new.json').exists()
    # the default output in the run and a file elsewhere are still written
    assert main(['evaluate', str(run), '--truth', str(truth)]) == 0
    assert main(['evaluate', str(run), '--truth', str(truth), '--output',
                 str(run / 'bag' / 'evaluation.json')]) == 0


def test_evaluate_output_directory_or_unwritable(bags, tmp_path: Path, capsys,
                                                 monkeypatch) -> None:
    """A directory, a missing directory or a failed write: one line, no partial file."""
    run, truth = bags
    assert main(['evaluate', str(run), '--truth', str(truth), '--output', str(tmp_path)]) == 2
    assert 'is a directory; give a file name' in _error(capsys)
    missing = tmp_path / 'no' / 'm.json'
    assert main(['evaluate', str(run), '--truth', str(truth), '--output', str(missing)]) == 2
    assert f'directory {missing.parent} does not exist' in _error(capsys)
    out = tmp_path / 'out' / 'm.json'
    out.parent.mkdir()
    out.write_text('old')

    def refuse(*args) -> None:
        raise PermissionError(13, 'Permission denied')

    monkeypatch.setattr(os, 'replace', refuse)
    assert main(['evaluate', str(run), '--truth', str(truth), '--output', str(out)]) == 2
    assert _error(capsys).endswith(f'cannot write {out}: Permission denied')
    assert [p.name for p in out.parent.iterdir()] == ['m.json'] and out.read_text() == 'old'


def test_evaluate_refuses_a_truth_from_another_time(tmp_path: Path, bags, capsys) -> None:
    """Truth and run that never overlap: exit 2 naming both; partly: a warning, also in JSON."""
    run, _ = bags
    t = np.arange(0.0, 1000.0, 10.0)
    true_u = 0.05 + 0.55 * t / 600.0
    late = tmp_path / 'late'
    _write(late, TRUTH_FRICTION, [(1e5 + ti, ui, ui, 0.0) for ti, ui in zip(t, true_u)])
    assert main(['evaluate', str(run), '--truth', str(late)]) == 2
    line = _error(capsys)
    assert "the run's predictions are stamped 0-590 s, the truth" in line
    assert '100000-100990 s: they do not overlap' in line
    partly = tmp_path / 'partly'
    _write(partly, TRUTH_FRICTION, [(ti, ui, ui, 0.0) for ti, ui in zip(t, true_u) if ti >= 300])
    out = tmp_path / 'm.json'
    assert main(['evaluate', str(run), '--truth', str(partly), '--output', str(out)]) == 0
    [warning] = capsys.readouterr().err.splitlines()
    assert warning.startswith('gear-phm evaluate: warning: ') and 'only partly' in warning
    assert json.loads(out.read_text())['warnings'] == [warning.split('warning: ', 1)[1]]


@pytest.mark.parametrize('text, message', [
    ('a,b\n0,500\n', "line 1: the header must name the columns time,true_eol, got 'a,b'"),
    ('0,500\n', "line 1: the header must name the columns time,true_eol, got '0,500'"),
    ('time,true_eol\n', 'holds a header but no time,true_eol row'),
    ('time,true_eol\n0,500\n100,nan\n', 'line 3 column true_eol: expected a finite number > 0'),
    ('time,true_eol\n0,1e309\n', 'line 2 column true_eol: expected a finite number > 0'),
    ('time,true_eol\n0,-5\n', 'line 2 column true_eol: expected a finite number > 0'),
    ('time,true_eol\n0,0\n', 'line 2 column true_eol: expected a finite number > 0'),
    ('time,true_eol\n-1,500\n', 'line 2 column time: expected a finite number >= 0'),
    ('time,true_eol\n0\n', "line 2 column true_eol: expected a finite number > 0 [s], got ''"),
])
def test_evaluate_truth_csv_needs_its_columns_and_finite_values(bags, tmp_path: Path, capsys,
                                                                text: str,
                                                                message: str) -> None:
    run, _ = bags
    csv = tmp_path / 'truth.csv'
    csv.write_text(text)
    out = tmp_path / 'm.json'
    assert main(['evaluate', str(run), '--truth', str(csv), '--output', str(out)]) == 2
    line = _error(capsys)
    assert f'{csv} ' in line and message in line, line
    assert not out.exists()


def test_evaluate_warns_when_the_run_ends_long_before_the_end_of_life(bags, tmp_path: Path,
                                                                      capsys) -> None:
    """A true end of life far beyond the run: alpha-lambda scores the last prediction, said."""
    run, _ = bags
    csv = tmp_path / 'truth.csv'
    csv.write_text('time , true_eol\n0,1e308\n')
    out = tmp_path / 'm.json'
    assert main(['evaluate', str(run), '--truth', str(csv), '--output', str(out)]) == 0
    [warning] = capsys.readouterr().err.splitlines()
    assert "the run's last prediction at 590 s comes before lambda 0.75" in warning
    assert json.loads(out.read_text())['warnings'] == [warning.split('warning: ', 1)[1]]


@pytest.mark.parametrize('option, message', [
    (['--lambdas', '0.5', '1.5'], '--lambdas must be in [0, 1) (a fraction of the life), got 1.5'),
    (['--band-from', '-0.1'], '--band-from must be in [0, 1) (a fraction of the life), got -0.1'),
    (['--alpha', 'inf'], '--alpha must be a fraction of the true RUL in (0, 1), got inf'),
    (['--alpha', '0'], '--alpha must be a fraction of the true RUL in (0, 1), got 0.0'),
    (['--alpha', 'nan'], '--alpha must be a fraction of the true RUL in (0, 1), got nan'),
    (['--t-start', 'nan'], '--t-start must be finite, got nan'),
])
def test_evaluate_option_ranges_name_the_option(bags, capsys, option: list[str],
                                                message: str) -> None:
    run, truth = bags
    assert main(['evaluate', str(run), '--truth', str(truth), *option]) == 2
    assert _error(capsys).endswith(message)
    assert not (run / 'bag' / 'evaluation.json').exists()


def test_vector_topics_decode_in_batches_as_rosbags_does(tmp_path: Path) -> None:
    """The batch decoder against rosbags' messages, and the fallback for what it refuses.

    Frame ids of every length modulo 8 (the values' alignment), stamps out of log order, a
    negative second; a big-endian payload (valid CDR that the batch decoder refuses) sends the
    topic through rosbags, with the same result.
    """
    from rosbags.typesys import get_typestore, Stores

    from gear_phm.bagio import BagReader
    from gear_phm.bagio.series import read_vector_topic
    from gear_phm.codec import decode_vector3_stamped_buffer, packed
    from gear_phm.interfaces import VECTOR3_STAMPED_TYPE

    store = get_typestore(Stores.ROS2_JAZZY)
    Vector3Stamped, Header, Time, Vector3 = (store.types[name] for name in (
        VECTOR3_STAMPED_TYPE, 'std_msgs/msg/Header', 'builtin_interfaces/msg/Time',
        'geometry_msgs/msg/Vector3'))
    rng = np.random.default_rng(7)
    msgs = [Vector3Stamped(Header(Time(int(sec), int(nsec)), 'f' * (i % 11)),
                           Vector3(*rng.standard_normal(3)))
            for i, (sec, nsec) in enumerate(zip(rng.integers(-5, 100, 40),
                                                rng.integers(0, 10**9, 40)))]
    little = [bytes(store.serialize_cdr(m, VECTOR3_STAMPED_TYPE)) for m in msgs]
    stamps, values = decode_vector3_stamped_buffer(*packed(little))
    assert stamps.tolist() == [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec
                               for m in msgs]
    assert values.tolist() == [[m.vector.x, m.vector.y, m.vector.z] for m in msgs]
    big = bytes(store.serialize_cdr(msgs[3], VECTOR3_STAMPED_TYPE, little_endian=False))
    assert decode_vector3_stamped_buffer(*packed(little + [big])) is None
    assert decode_vector3_stamped_buffer(*packed([little[0][:-1]])) is None     # truncated
    for name, payloads in (('fast', little), ('fallback', little + [big])):
        with Rosbag2McapWriter(tmp_path / name, compression=None) as writer:
            writer.add_topic(HEALTH_RUL, VECTOR3_STAMPED_TYPE)
            for k, payload in enumerate(payloads):
                writer.write_raw(HEALTH_RUL, 10**9 + k, payload)
        with BagReader(tmp_path / name) as bag:
            expected = sorted(((m.header.stamp.sec * 10**9 + m.header.stamp.nanosec) * 1e-9,
                               m.vector.x, m.vector.y, m.vector.z)
                              for _, _, m in bag.messages([HEALTH_RUL]))
        times, vectors = read_vector_topic(tmp_path / name, HEALTH_RUL)
        assert len(times) == len(payloads)
        assert np.column_stack([times, vectors]).tolist() == [list(r) for r in expected]


@pytest.mark.parametrize('changes, message', [
    ({'alpha': 1.0}, r'^--alpha must be a fraction of the true RUL in \(0, 1\), got 1\.0$'),
    ({'lambdas': [0.5, 1.0]}, r'^--lambdas must be in \[0, 1\) .* got 1\.0$'),
    ({'band_from': -0.1}, r'^--band-from must be in \[0, 1\) .* got -0\.1$'),
    ({'t_start': math.inf}, r'^--t-start must be finite, got inf$'),
])
def test_option_ranges_are_checked_with_one_line(changes: dict, message: str) -> None:
    import argparse

    from gear_phm.cli.evaluate import _check_options
    from gear_phm.cli.main import CliError
    good = {'alpha': 0.2, 'lambdas': [0.0, 0.5, 0.75], 'band_from': 0.5, 't_start': None}
    _check_options(argparse.Namespace(**good))
    with pytest.raises(CliError, match=message):
        _check_options(argparse.Namespace(**{**good, **changes}))


def test_printed_metrics_are_rounded_and_an_infinite_one_explained(tmp_path: Path,
                                                                   capsys) -> None:
    """Infinite RUL predictions early in the life: CRA is -inf, and the line says why."""
    t = np.arange(0.0, 1000.0, 10.0)
    true_u = 0.05 + 0.55 * t / 600.0
    _write(tmp_path / 'truth', TRUTH_FRICTION, [(ti, ui, ui, 0.0) for ti, ui in zip(t, true_u)])
    ruls = 1.1 * (600.0 - t[t < 600.0])
    ruls[:5] = np.inf
    _write(tmp_path / 'run' / 'bag', HEALTH_RUL,
           [(ti, r, 0.8 * r, 1.2 * r) for ti, r in zip(t, ruls)])
    assert main(['evaluate', str(tmp_path / 'run'), '--truth', str(tmp_path / 'truth')]) == 0
    text = capsys.readouterr().out
    assert 'cumulative relative accuracy: -inf (a prediction of infinite RUL scores RA -inf)' \
        in text
    assert 'RUL 495 s vs true 450 s, RA 0.9)' in text           # 495.00000000000006, 0.89999..
    assert 'RUL finite from lambda 0.0833\n' in text
