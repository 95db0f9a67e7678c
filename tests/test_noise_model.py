"""The simulator against the model's own Allan variance (tinygp style: simulated moments
against the model's covariance), term by term and together."""

import jax
import numpy as np
import pytest

import bayescal as bc
from bayescal.models.effects.biquad_filter import BIQUAD_RADIUS, BiquadFilter
from bayescal.models.effects.output_filter import OutputFilter

RATE = 100.0
N_SAMPLES = 2**14
REPLICAS = 256

TERMS = {
    "white": dict(N=0.01),
    "rate_random_walk": dict(K=2e-3),
    "bias_instability": dict(B=5e-3),
    "quantization": dict(Q=2e-4),
    "rate_ramp": dict(R=1e-4),
    "output_filter": dict(N=0.01, F=0.4),
    "gauss_markov": dict(N=0.01, gm_sigma=5e-3, gm_tau=0.5),
    "all": dict(N=0.01, K=2e-4, B=1e-3, Q=1e-4, R=1e-6, F=0.2),
    "biquad_filter": dict(
        N=0.01, **OutputFilter(shape="biquad", poles=(-0.6, 0.3), zeros=(0.7, 0.5)).values
    ),
    # Lines of random phase: their Allan variance is DESIGN.md's, at the samples' amplitude.
    "spectral_lines": dict(N=0.01, line_frequency=(3.7, 21.0), line_amplitude=(0.02, 0.05)),
}


@pytest.mark.parametrize("term", list(TERMS))
def test_simulated_allan_variance_matches_model(term):
    model = bc.NoiseModel(rate_hz=RATE, bias=0.3, **TERMS[term])
    keys = jax.random.split(jax.random.PRNGKey(42), REPLICAS)
    samples = np.asarray(jax.jit(jax.vmap(lambda key: model.sample(key, N_SAMPLES)))(keys))
    result = bc.allan_deviation(samples, RATE, "octave", noise_type=0)
    keep = result.m <= N_SAMPLES // 8
    variance = result.deviation[:, keep] ** 2
    expected = np.asarray(model.allan_variance(result.tau[keep]))
    if term == "rate_ramp":  # deterministic: every replica gives R^2 tau^2 / 2
        np.testing.assert_allclose(variance, np.broadcast_to(expected, variance.shape), rtol=1e-6)
        return
    standard_error = variance.std(axis=0, ddof=1) / np.sqrt(REPLICAS)
    z = (variance.mean(axis=0) - expected) / standard_error
    # 11 averaging times per term: |z| < 4 for all of them fails by chance with p < 1e-3.
    assert np.all(np.abs(z) < 4), z


def test_same_key_same_samples_and_bias_is_the_start():
    model = bc.NoiseModel(rate_hz=RATE, bias=0.3, N=0.01, K=1e-3, B=1e-3)
    first = model.sample(jax.random.PRNGKey(1), 1000)
    np.testing.assert_array_equal(first, model.sample(jax.random.PRNGKey(1), 1000))
    assert not np.array_equal(first, model.sample(jax.random.PRNGKey(2), 1000))
    keys = jax.random.split(jax.random.PRNGKey(3), 4000)
    starts = jax.vmap(lambda key: model.sample(key, 64)[0])(keys)
    # The first sample is the turn-on bias plus the first period's noise.
    assert abs(float(np.mean(starts)) - 0.3) < 4 * float(np.std(starts)) / np.sqrt(4000)


def test_rejects_a_non_positive_rate():
    with pytest.raises(ValueError, match="rate_hz"):
        bc.NoiseModel(rate_hz=0.0)


def test_a_biquad_is_the_second_order_section_scipy_filters_with():
    """The biquad's |H|^2 from its reflection coefficients against scipy's frequency response
    of the same section (a digital Butterworth at the output rate, its double zero at Nyquist
    moved inside the biquad's radius), normalised to unit gain at zero frequency."""
    from scipy import signal

    def reflections(c):  # the inverse of c2 = rho^2 k2, c1 = rho k1 (1 + k2)
        k2 = c[2] / BIQUAD_RADIUS**2
        return c[1] / (BIQUAD_RADIUS * (1 + k2)), k2

    _, a = signal.butter(2, 30.0, fs=RATE)
    b = np.poly([-0.899, -0.899])  # the Butterworth's (1 + z^-1)^2, its zeros inside
    lowpass = OutputFilter(shape="biquad", poles=reflections(a), zeros=reflections(b))
    nu = np.linspace(0.0, 0.49, 50)
    _, response = signal.freqz(b, a, worN=nu * RATE, fs=RATE)
    expected = np.abs(response) ** 2 / np.abs(response[0]) ** 2
    gain = np.asarray(lowpass.shape_gain(nu, RATE))
    np.testing.assert_allclose(gain, expected, rtol=1e-9, atol=1e-15)
    assert OutputFilter.from_values("biquad", lowpass.values).values == lowpass.values


def test_no_biquad_has_a_pole_or_zero_near_zero_frequency():
    """Over coordinates as far out as the prior reaches (sd 1.5, here up to 6 sd), every
    section is flat near zero frequency: within 1 % of unit gain at fs / 1000. A pole near
    z = 1 (a Gauss-Markov process disguised as the output filter) would step there: one at
    0.99 loses 28 % of the power at fs / 1000. And the radius is reached (a section with a
    pole pair on it drops by a factor of ten or more within the band)."""
    coordinates = np.random.default_rng(0).uniform(-9.0, 9.0, (4, 20_000))
    names = [parameter.name for parameter in BiquadFilter.parameters]
    values = dict(zip(names, np.tanh(coordinates), strict=True))  # the biquad's coordinate
    near_zero = np.asarray(BiquadFilter.gain(1e-3, values, RATE))
    assert np.max(np.abs(near_zero - 1.0)) < 0.01
    assert BIQUAD_RADIUS <= 0.9
    nu = np.linspace(0.01, 0.5, 50)[:, None]
    lowest = np.asarray(BiquadFilter.gain(nu, values, RATE)).min()
    assert lowest < 0.1
