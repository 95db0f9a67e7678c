"""The small seeded version of benchmarks/noise_high_frequency.py: where a record is not white
at high frequency (a Butterworth low-pass at or above the output rate, white angle noise,
rounding), the default ``noise`` keeps N the low-frequency level, and discovery names what
shaped it."""

import numpy as np
import pytest
from _benchmarks import load_benchmark

import bayescal as bc

bench = load_benchmark("noise_high_frequency")

SAMPLES = 2**15
SHAPE = {
    "butterworth": {"butterworth_filter", "decimation_filter", "output_filter", "biquad_filter"},
    "butterworth_at_rate": {
        "butterworth_filter",
        "decimation_filter",
        "output_filter",
        "biquad_filter",
    },
    "white_angle": {"quantization"},
    "quantization": set(),
}


@pytest.mark.parametrize("kind", bench.KINDS)
def test_default_noise_keeps_n_the_low_frequency_level(kind):
    """N within 5 % of the truth and within 3 posterior sd of it (the benchmark measures the
    90 % intervals' coverage over 100 records), the record's shape among the terms chosen,
    the model fits and its sampler passed; the classical three-term model, for contrast, is
    bent by the filtered records' high frequencies."""
    values, shaped = bench.simulate(kind, SAMPLES, seed=11)
    fit = bc.fit_noise(values, bench.RATE, unit="deg/s", seed=0)
    n = fit.parameters["N"]
    assert abs(n.mean / shaped["N"] - 1) < 0.05
    assert abs(n.mean - shaped["N"]) < 3 * n.sd
    assert fit.passed, fit.failures
    if SHAPE[kind]:
        assert SHAPE[kind] & set(fit.terms), fit.terms
    if kind == "quantization":
        assert fit.lsb > 0 and fit.output_white_level > n.mean
    if kind == "butterworth_at_rate":
        classical = bench.classical_model_n(values, fit.classical.allan)
        assert abs(classical / shaped["N"] - 1) > 0.2


def test_discovery_names_the_grid_and_never_outliers():
    """An accelerometer on 8 levels (sd 0.75 LSB) is quantization, with the LSB as its
    parameter: no samples are replaced as outliers, and the discrete-levels check passes."""
    rate, sd = 100.0, 0.01 * np.sqrt(100.0)
    values = bc.NoiseModel(rate_hz=rate, N=0.01, lsb=sd / 0.75).simulate(2**14, seed=1)
    found = bc.discover(values, rate, unit="g", posterior=False)
    names = [effect.name for effect in found.effects]
    assert names == ["quantization"]
    assert found.effects[0].parameters["lsb"]["value"] == pytest.approx(sd / 0.75)
    assert all(check.passed_after for check in found.checks if check.name == "discrete_levels")


@pytest.mark.parametrize(("kind", "seed"), [("quantization", 3002), ("butterworth_at_rate", 1004)])
def test_a_clean_record_on_a_grid_has_no_glitches(kind, seed):
    """Two of the benchmark's clean records whose details span only a few grid steps (an LSB
    of half the noise sd; a 16-bit part's filtered output): a median absolute deviation, which
    can only be a grid point, put their spread 14-20 % low, and the outlier scan took 94
    good samples of the first for glitches. The grouped spread holds the scores' sd to 1."""
    from bayescal.models.effects.outliers import outlier_scan, robust_scores

    values, _ = bench.simulate(kind, 2**16, seed)
    assert abs(np.std(robust_scores(values)) - 1) < 0.03
    scan = outlier_scan(values)
    assert scan["log_bayes_factor"] < 0 and not scan["flagged"].any()


def test_discovery_names_the_output_filter():
    """A Butterworth low-pass at the output rate (rounded as a 16-bit part's output) is the
    output filter: the baseline's spectrum misfits toward Nyquist and the shape fixes it."""
    values, _ = bench.simulate("butterworth_at_rate", 2**14, seed=3)
    found = bc.discover(values, bench.RATE, unit="deg/s", posterior=False)
    names = [effect.name for effect in found.effects]
    assert "output_filter" in names and "outliers" not in names
    spectrum = next(check for check in found.checks if check.name == "spectrum_bands")
    assert not spectrum.passed_before and spectrum.passed_after


def test_a_filter_shape_that_bends_n_gives_way_to_the_biquad():
    """A second-order Butterworth at 1 kHz read at 200 Hz: the one-tap filter wins the
    evidence, not decisively, with N 4 % high and a 0.8 % sd; its N is many sds from the
    biquad's (Hausman), so the biquad is kept, says why, and its interval covers the truth."""
    values, shaped = bench.simulate("butterworth", 2**14, seed=0)
    fit = bc.fit_noise(values, bench.RATE, unit="deg/s", seed=0)
    trials = {trial.term: trial for trial in fit.selection.trials}
    assert trials["biquad_filter"].kept
    assert "Hausman" in trials["biquad_filter"].reason
    assert 0 < trials["output_filter"].log_bayes_factor < fit.selection.threshold
    assert trials["output_filter"].reason.endswith("it bends N")
    n = fit.parameters["N"]
    assert n.q05 <= shaped["N"] <= n.q95
    assert fit.passed, fit.failures


def test_a_steep_butterworth_has_a_gradient_far_above_its_corner():
    """A steep Butterworth (order 5,900, as a MAP's search passed through) far above its
    corner: ratio^(2n) overflows, the gain is zero, and so is its gradient — not NaN, on
    which the MAP's BFGS stalled to its step limit (2,000 steps, 0.15 s of a fit)."""
    import jax

    from bayescal.models.effects.butterworth_filter import ButterworthFilter

    def gain_at_half_rate(order):
        values = {"filter_cutoff": 10.0, "filter_order": order, "filter_warping": 0.5}
        return ButterworthFilter.gain(0.45, values, 100.0)

    assert float(gain_at_half_rate(5900.0)) == 0.0
    assert float(jax.grad(gain_at_half_rate)(5900.0)) == 0.0
    assert np.isfinite(float(jax.grad(gain_at_half_rate)(2.0)))
