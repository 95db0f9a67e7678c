"""Classical numbers of a static channel: slope readings and the Student-t check, on
simulations with known parameters."""

import numpy as np
import pytest

import bayescal as bc

RATE = 100.0


def simulate(seed, n, **parameters):
    return bc.NoiseModel(rate_hz=RATE, bias=0.5, **parameters).simulate(n, seed=seed)


def test_white_noise_readings_and_valid_interval():
    y = simulate(1, 2**18, N=0.004)
    result = bc.classical_noise(y, RATE)
    n = result.slope_readings["N"]
    assert n.kind == "reading" and n.ci_low < 0.004 < n.ci_high
    assert result.slope_readings["K"].kind == "upper_bound"
    assert result.slope_readings["B"].kind == "upper_bound"  # still falling at the longest tau
    assert result.t_interval.valid and result.t_interval.widening == 1.0
    assert result.bias_ci_low < 0.5 < result.bias_ci_high


def test_random_walk_is_read_on_its_slope_and_breaks_the_t_interval():
    y = simulate(2, 2**20, N=0.005, K=1e-3)
    result = bc.classical_noise(y, RATE)
    n, k = result.slope_readings["N"], result.slope_readings["K"]
    assert n.kind == "reading" and n.ci_low < 0.005 < n.ci_high
    assert k.kind == "reading" and abs(k.local_slope - 0.5) < 0.125
    assert k.ci_low < 1e-3 < k.ci_high
    assert not result.t_interval.valid
    assert result.t_interval.widening == result.t_interval.ratio > 3


def test_upper_bounds_hold_above_the_truth():
    """Where a term's slope is absent its value is bounded, and the bound sits above the
    truth: white noise dominates everywhere here, so Q, K and B are bounds."""
    y = simulate(3, 2**16, N=0.01, K=1e-5, Q=1e-6)
    readings = bc.classical_noise(y, RATE).slope_readings
    assert readings["Q"].kind == "upper_bound" and readings["Q"].ci_high > 1e-6
    assert readings["K"].kind == "upper_bound" and readings["K"].ci_high > 1e-5


def test_an_output_filter_does_not_lower_the_bound_below_the_truth():
    """A 4-sample moving average (unit gain at zero frequency) lowers the Allan curve at one
    sample period to a quarter of the white noise's line: a bound read there would sit at a
    quarter of the record's N. The bound is read from ten sample periods on, where the
    filter's reach has shrunk to a few percent (5-8 % at 16 periods), within the 10 %
    materiality the readings use."""
    from bayescal.classical._noise import _upper_bound

    rng = np.random.default_rng(4)
    n_true = 0.01
    white = rng.normal(0.0, n_true * np.sqrt(RATE), 2**16 + 3)
    filtered = np.convolve(white, np.ones(4) / 4, mode="valid")
    allan = bc.allan_deviation(filtered, RATE, "octave")
    line = 1 / np.sqrt(allan.tau)
    assert allan.deviation[0] / line[0] < 0.3 * n_true  # the filter's dip the old bound read
    bound = _upper_bound(allan, line, "test")
    assert bound.ci_high > 0.9 * n_true and bound.tau_s >= 10 / RATE


def test_student_t_interval_ignores_missing_samples():
    values = np.array([1.0, 2.0, np.nan, 3.0])
    mean, _, high = bc.student_t_interval(values, 0.95)
    assert mean == 2.0
    assert high - mean == pytest.approx(4.302652729911275 * 1.0 / np.sqrt(3))
