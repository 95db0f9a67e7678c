"""Saturation against truth: a clipped normal's mean and spread are recovered from the
censored likelihood; a coarse converter step alone is not taken for a rail; discovery names a
rail concealed in the noise's tail and corrects what the clipped record would report."""

import json
import math

import numpy as np
import pytest
from recording_files import write_csv

import bayescal as bc
from bayescal.inference._discovery_search import DECISIVE_LOG_BAYES_FACTOR
from bayescal.models.effects.saturation import impute_clipped, saturation_scan
from bayescal.recording._levels import discrete_step, rail_check

N = 20_000


def _scan(values):
    return saturation_scan(values)


@pytest.mark.parametrize("step", [0.0, 0.1, 0.5])
@pytest.mark.parametrize("rail_sd", [1.0, 2.5])
def test_censored_fit_recovers_the_unclipped_mean_and_spread(step, rail_sd):
    rng = np.random.default_rng(int(10 * rail_sd + 100 * step))
    truth = rng.normal(3.0, 2.0, N)
    values = np.minimum(truth, 3.0 + 2.0 * rail_sd)
    if step:
        values = np.round(values / (2.0 * step)) * (2.0 * step)  # step in units of the sd
    scan = _scan(values)
    assert scan["log_bayes_factor"] > DECISIVE_LOG_BAYES_FACTOR
    assert list(scan["rails"]) == ["upper"]
    # Standard errors of a normal's mean and sd from N samples, times what censoring 16 % of
    # them costs (asymptotically 1.02 and 1.13).
    assert abs(scan["mean"] - 3.0) < 4 * 2.0 / math.sqrt(N) * 1.1
    assert abs(scan["sd"] - 2.0) < 4 * 2.0 / math.sqrt(2 * N) * 1.2
    # The clipped record's own mean is pulled in far beyond its standard error.
    if rail_sd == 1.0:
        assert 3.0 - values.mean() > 10 * values.std() / math.sqrt(N)


@pytest.mark.parametrize("step", [0.1, 0.5, 1.0])
def test_a_coarse_converter_step_is_not_taken_for_a_rail(step):
    """Unclipped samples on a coarse grid share their extreme level: no decisive rail, and the
    rail check passes, over 20 records."""
    for seed in range(20):
        values = np.round(np.random.default_rng(seed).normal(0.0, 1.0, N) / step) * step
        scan = _scan(values)
        assert scan is None or scan["log_bayes_factor"] < DECISIVE_LOG_BAYES_FACTOR
        assert rail_check(values, 50.0, "deg/s")["p_value"] > 0.01


def test_unclipped_continuous_samples_have_no_rail():
    values = np.random.default_rng(0).normal(0.0, 1.0, N)
    assert _scan(values) is None
    assert rail_check(values, 50.0, "deg/s")["p_value"] == 1.0


@pytest.mark.parametrize("step", [0.0, 0.5])
def test_imputation_restores_the_spread_on_the_record_grid_and_is_seeded(step):
    truth = np.random.default_rng(1).normal(0.0, 1.0, 4 * N)
    values = np.minimum(truth, 1.0)
    if step:
        values = np.round(values / step) * step
    scan = _scan(values)
    first = impute_clipped(values, scan, np.random.default_rng(7))
    np.testing.assert_array_equal(first, impute_clipped(values, scan, np.random.default_rng(7)))
    clipped = values == 1.0
    assert np.all(first[clipped] >= 1.0) and np.array_equal(first[~clipped], values[~clipped])
    assert discrete_step(first) == pytest.approx(step)
    # Without imputation the mean is 0.09 low and the sd 0.14 short (measured on this draw).
    assert abs(first.mean()) < 4 / math.sqrt(4 * N) and abs(first.std() - 1) < 0.01


def test_a_rail_on_each_side_and_gaps():
    values = np.clip(np.random.default_rng(2).normal(0.0, 1.0, N), -1.5, 1.5)
    values[1000:1100] = np.nan
    scan = _scan(values)
    assert scan["log_bayes_factor"] > DECISIVE_LOG_BAYES_FACTOR
    assert {side: rail["value"] for side, rail in scan["rails"].items()} == {
        "upper": 1.5,
        "lower": -1.5,
    }
    assert abs(scan["mean"]) < 4 / math.sqrt(N) and abs(scan["sd"] - 1) < 4 / math.sqrt(N)
    assert np.isnan(impute_clipped(values, scan, np.random.default_rng(0))[1000:1100]).all()


def test_repeated_glitches_far_outside_the_noise_are_not_a_rail():
    """Three samples on one error code 50 sd out: glitches (outliers), not clipped noise."""
    values = np.random.default_rng(3).normal(0.0, 1.0, N)
    values[[10, 5000, 9000]] = 50.0
    assert _scan(values) is None
    assert rail_check(values, 50.0, "deg/s")["p_value"] == 1.0


def test_discovery_names_a_rail_concealed_in_the_noise_tail():
    """A rail 3 sd above the bias clips 0.13 % of the samples (16 of 14 400 in this draw): invisible
    in a plot, named, nothing else added, the spread recovered."""
    rng = np.random.default_rng(11)
    values = np.minimum(0.1 + 0.05 * rng.standard_normal(14_400), 0.1 + 3 * 0.05)
    found = bc.discover(values, 20.0, unit="deg/s", posterior=False)
    assert [effect.name for effect in found.effects] == ["saturation"]
    rail = {check.name: check for check in found.checks}["rail"]
    assert not rail.passed_before and rail.location["rail"] == pytest.approx(0.25)
    assert found.final_terms == ("bias", "white", "saturation")
    unclipped_sd = found.effects[0].evidence["unclipped_sd"]
    assert abs(unclipped_sd - 0.05) < 4 * 0.05 / math.sqrt(2 * values.size)


def test_cli_reports_the_rail_and_the_unclipped_mean(run_cli, tmp_path):
    """A gyro on a rate table near its full scale: 16 % of samples at the rail. The classical
    mean is off by more than ten of its standard errors; discovery's unclipped mean is not,
    and the white noise's posterior covers its true value."""
    rate, n, mean, sd, rail = 50.0, 30_000, 245.0, 2.0, 247.0
    values = np.minimum(mean + sd * np.random.default_rng(5).standard_normal(n), rail)
    path = write_csv(
        tmp_path / "table.csv", {"time": np.arange(n) / rate, "gyro_z[deg/s]": values}, fmt="%.6f"
    )
    output, folder = tmp_path / "findings.json", tmp_path / "report"
    code, stdout, stderr = run_cli(
        "discover", path, "--channel", "gyro_z", "--json", output, "--out", folder, "--quiet"
    )
    assert code == 0, stderr
    document = json.loads(output.read_text())
    assert [effect["name"] for effect in document["effects"]] == ["saturation"]
    effect = document["effects"][0]
    assert effect["location"]["rail"] == rail and effect["location"]["unit"] == "deg/s"
    evidence = effect["evidence"]
    standard_error = sd / math.sqrt(n)
    assert abs(evidence["unclipped_mean"] - mean) < 5 * standard_error
    assert mean - evidence["clipped_mean"] > 10 * standard_error
    white = document["posterior"]["parameters"]["N"]
    assert white["q05"] < sd / math.sqrt(rate) < white["q95"]
    assert "upper rail 247 deg/s" in stdout and "unclipped mean" in stdout
    assert (folder / "discover_gyro_z_distribution.png").stat().st_size > 1000
    # Every command that reads the channel is told (a mean of it would be biased).
    notes = bc.load_recording(path).channel("gyro_z").notes
    assert any("clipped" in note and "247 deg/s" in note for note in notes)
