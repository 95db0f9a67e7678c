"""The spectral likelihood: binning is exact to well below the statistical error, the
expected periodogram is what simulated periodograms average to, and the closed-form
autocovariances are the Fourier pairs of the spectra."""

from types import SimpleNamespace

import jax
import numpy as np
import pytest
from scipy import fft
from scipy.signal import windows

import bayescal as bc
from bayescal.models._components import Components
from bayescal.models._whittle import (
    BIN_BUCKET,
    SEGMENT_BUCKET,
    TAPER_FRACTION,
    _expected_periodogram,
    expected_power,
    padded_index,
    padded_summary,
    spectral_summary,
    whittle_log_likelihood,
)
from bayescal.models.effects._parameter import Context
from bayescal.models.effects.bias_instability import BiasInstability
from bayescal.models.effects.gauss_markov import GaussMarkov

RATE = 100.0
TRUE = {"N": 0.005, "B": 5e-4, "K": 5e-6, "Q": 1e-5, "F": 0.2}
COMPONENTS = Components.of(
    ("quantization", "white", "output_filter", "bias_instability", "rate_random_walk"),
    Context(RATE),
)


def variances(**scale):
    values = {p: v * scale.get(p, 1.0) for p, v in TRUE.items()}
    return np.asarray(COMPONENTS.weights(values))


def summary_of(record, **options):
    return spectral_summary(record, RATE, components=COMPONENTS, **options)


@pytest.fixture(scope="module")
def record():
    return bc.NoiseModel(rate_hz=RATE, bias=0.3, **TRUE).simulate(2**15, seed=0)


def test_binning_matches_every_frequency(record):
    """Log-likelihood differences between nearby models, binned and at every frequency, agree
    to within 1 % of their own statistical sd (the ordinates' scatter): the binning costs no
    information that matters."""
    binned = summary_of(record)
    exact = summary_of(record, bin_width=1e-12)
    assert binned.n_bins < exact.n_bins / 40
    base = variances()
    for change in ({"N": 1.01}, {"B": 1.5}, {"K": 3.0}, {"Q": 0.3, "N": 0.99}, {"F": 0.5}):
        shifted = variances(**change)
        difference_binned = float(
            np.sum(whittle_log_likelihood(binned, shifted))
            - np.sum(whittle_log_likelihood(binned, base))
        )
        difference_exact = float(
            np.sum(whittle_log_likelihood(exact, shifted))
            - np.sum(whittle_log_likelihood(exact, base))
        )
        # Each ordinate's term -log S' - I / S' + log S + I / S has sd |1 - S / S'|.
        ratio = np.asarray(expected_power(exact, base) / expected_power(exact, shifted))
        sd = float(np.sqrt(np.sum((exact.weight * (1 - ratio)) ** 2)))
        assert abs(difference_binned - difference_exact) < 0.01 * sd, change


def test_a_spectral_zero_is_never_rewarded():
    """A model whose spectrum vanishes where the record has power loses likelihood, however
    steep its fall inside a bin: the binned terms' weights are never negative."""
    record = bc.NoiseModel(rate_hz=RATE, N=0.01).simulate(2**14, seed=1)
    summary = summary_of(record)
    white = np.asarray(COMPONENTS.weights({"N": 0.01}))
    flat = float(np.sum(whittle_log_likelihood(summary, white)))
    nu = summary.node_frequency
    rest = white.copy()
    rest[summary.shaped] = 0.0
    for cutoff in (0.05, 0.2, 0.4):  # a brick wall: gain 1e-12 above the cutoff
        gain = np.where(nu < cutoff, 1.0, 1e-12)
        walled = whittle_log_likelihood(summary, rest, filtered=(gain, white[summary.shaped]))
        assert float(np.sum(walled)) < flat - 1e3 * (0.5 - cutoff)


def test_expected_periodogram_is_the_average_periodogram():
    """The debiased likelihood's S_j: tapered periodograms of simulated increments average
    to it, down to the lowest frequencies (where leakage would otherwise dominate)."""
    n, replicas = 1024, 4000
    model = bc.NoiseModel(rate_hz=RATE, N=0.01, K=1e-3, B=2e-3, F=0.3)
    samples = np.asarray(
        jax.jit(jax.vmap(lambda key: model.sample(key, n)))(
            jax.random.split(jax.random.PRNGKey(5), replicas)
        )
    )
    increments = np.diff(samples, axis=1)
    taper = windows.tukey(increments.shape[1], TAPER_FRACTION)
    centred = increments - (increments @ taper / taper.sum())[:, None]
    periodogram = np.abs(fft.rfft(taper * centred, axis=1)) ** 2 / np.sum(taper**2)
    index = np.arange(1, 40)
    basis = _expected_periodogram(
        taper.size, RATE, TAPER_FRACTION, tuple(index.tolist()), COMPONENTS.shapes
    )
    expected = np.asarray(COMPONENTS.weights({"N": 0.01, "B": 2e-3, "K": 1e-3, "F": 0.3})) @ basis
    mean = periodogram[:, index].mean(axis=0)
    standard_error = periodogram[:, index].std(axis=0) / np.sqrt(replicas)
    assert np.all(np.abs(mean - expected) < 4 * standard_error)


def test_autocovariances_are_fourier_pairs_of_the_spectra():
    """Every component's closed-form increment autocovariance against the numerical inverse
    transform of its closed-form spectrum (a Gauss-Markov shape at three correlation times
    among them)."""
    size = 2**15
    nu = np.arange(1, size // 2 + 1) / size
    weight = np.where(nu == 0.5, 0.5, 1.0)  # trapezoid rule; the zero-frequency end is added
    lags = np.arange(8)
    shapes = (*COMPONENTS.shapes, *(GaussMarkov(t) for t in (0.003, 0.1, 30.0)))
    for shape in shapes:
        spectrum = np.asarray(shape.spectrum(nu, RATE)) * weight
        zero = 0.5 * float(np.asarray(shape.spectrum(np.array([1e-12]), RATE))[0])
        numeric = [
            2 * (zero + np.sum(spectrum * np.cos(2 * np.pi * nu * lag))) / size for lag in lags
        ]
        autocovariance = shape.autocovariance(lags.astype(float), RATE)
        scale = abs(autocovariance[0])
        np.testing.assert_allclose(numeric, autocovariance, atol=1e-4 * scale, err_msg=str(shape))


def test_gauss_markov_between_its_nodes_is_its_exact_shape():
    """The Gauss-Markov term's weights interpolate its shape between the correlation times
    whose expected periodograms the summary holds: at correlation times halfway between
    nodes, the interpolated expected periodogram is within 0.1 % of the exact one at every
    bin (0.074 % at worst, measured at 2^14, 2^17 and 2^20 samples), from a correlation time
    of a few samples to one near the record's length."""
    n = 2**14
    context = Context(RATE, n / RATE)
    components = Components.of(("white", "gauss_markov"), context)
    record = bc.NoiseModel(rate_hz=RATE, N=0.01).simulate(n, seed=2)
    summary = spectral_summary(record, RATE, components=components)
    nodes = np.array([shape.time_constant_s for shape in components.shapes[1:]])
    for tau in np.sqrt(nodes[1:-2] * nodes[2:-1])[::5].tolist():
        weights = np.asarray(components.weights({"gm_sigma": 1.0, "gm_tau": tau}))
        interpolated = np.asarray(expected_power(summary, weights))
        exact_components = Components(
            (*components.terms[:1], GaussMarkov), (components.shapes[0], GaussMarkov(tau)), (1, 1)
        )
        exact = spectral_summary(record, RATE, components=exact_components)
        truth = np.asarray(expected_power(exact, np.array([0.0, 1.0])))
        assert np.max(np.abs(interpolated / truth - 1)) < 1e-3, tau


def test_flicker_difference_far_from_zero_uses_a_series_that_joins_the_direct_value():
    t = np.arange(20, 40, dtype=np.longdouble)

    def t2_log(x):
        return x * x * np.log(x)

    direct = t2_log(t + 2) - 4 * t2_log(t + 1) + 6 * t2_log(t) - 4 * t2_log(t - 1) + t2_log(t - 2)
    flicker = BiasInstability.autocovariance(t.astype(float), RATE) * (2 * np.pi)
    np.testing.assert_allclose(flicker, direct.astype(float), rtol=1e-9)


def test_padding_leaves_the_likelihood_and_serves_records_of_many_lengths(record):
    """The padded summary (bucketed bins and segments) gives the same log-likelihood, its
    pointwise values those of the summary followed by zeros, with a gap (two segments) too;
    records of 2^15 and 2^16 samples share its shapes."""
    with_gap = np.concatenate((record[:20000], [np.nan], record[20001:]))
    for values in (record, with_gap):
        summary = summary_of(values)
        padded = padded_summary(summary)
        assert padded.n_bins % BIN_BUCKET == 0 and padded.mean_increment.size == SEGMENT_BUCKET
        for scale in ({}, {"K": 3.0, "N": 0.9}):
            exact = np.asarray(whittle_log_likelihood(summary, variances(**scale), ramp=1e-4))
            pointwise = np.asarray(whittle_log_likelihood(padded, variances(**scale), ramp=1e-4))
            np.testing.assert_allclose(pointwise[padded_index(summary)], exact, rtol=1e-12)
            assert np.sum(np.abs(np.delete(pointwise, padded_index(summary)))) == 0.0
    longer = bc.NoiseModel(rate_hz=RATE, bias=0.3, **TRUE).simulate(2**16, seed=1)
    shapes = {
        tuple(leaf.shape for leaf in jax.tree_util.tree_leaves(padded_summary(summary_of(v))))
        for v in (record, longer)
    }
    assert len(shapes) == 1


def test_expected_periodogram_kept_on_disk_is_the_computed_one(tmp_path, monkeypatch):
    """The expected periodogram read back from the trace cache's folder is the one computed,
    and a second run reads it instead of computing it."""
    import bayescal.models._whittle as whittle

    monkeypatch.setenv("BAYESCAL_TRACE_CACHE", str(tmp_path))
    shapes = Components.of(("white", "rate_random_walk", "gauss_markov"), Context(RATE, 600.0))
    arguments = (4096, RATE, TAPER_FRACTION, (0, 1, 5, 40, 400), shapes.shapes)
    computed = whittle._expected_computed(*arguments[:3], np.asarray(arguments[3]), arguments[4])
    first = _expected_periodogram.__wrapped__(*arguments)
    assert len(list(tmp_path.glob("expected_periodogram-*.npy"))) == 1

    def fails(*_):
        raise AssertionError("computed again")

    monkeypatch.setattr(whittle, "_expected_computed", fails)
    second = _expected_periodogram.__wrapped__(*arguments)
    np.testing.assert_array_equal(first, computed)
    np.testing.assert_array_equal(second, computed)


def test_a_noise_fit_transforms_its_record_once_to_the_same_bits(monkeypatch):
    """The line scan's periodogram and the Whittle summaries read one transform of the
    record's increments, taken once by the fit's setup and handed to both
    (:func:`longest_run_transform`): the whole record is transformed once, and the lines
    and the summaries are those computed alone to the bit."""
    from bayescal.capabilities._noise import noise_setup
    from bayescal.classical import _periodogram
    from bayescal.classical._lines import find_lines
    from bayescal.models._noise_problem import noise_summaries
    from bayescal.models._terms import AUTO, CANDIDATE_TERMS

    values = bc.NoiseModel(rate_hz=RATE, bias=0.3, N=0.005, K=5e-6).simulate(2**15, seed=1)
    alone, _ = noise_summaries(values, RATE, ("white", *CANDIDATE_TERMS))
    lines = find_lines(values, RATE)
    lengths = []

    def counted(data, *arguments, **keywords):
        lengths.append(data.size)
        return fft.rfft(data, *arguments, **keywords)

    counting = SimpleNamespace(rfft=counted, next_fast_len=fft.next_fast_len)
    monkeypatch.setattr(_periodogram, "fft", counting)
    setup = noise_setup(values, RATE, AUTO, "deg/s")  # the terms' family, lines searched
    assert not any(finding.found for finding in setup.found.values())
    assert lengths.count(max(lengths)) == 1, lengths  # the record's increments, once
    assert setup.found["spectral_lines"].largest == lines.largest
    for kept, computed in zip(jax.tree.leaves(setup.spectral), jax.tree.leaves(alone), strict=True):
        assert np.array_equal(kept, computed)
