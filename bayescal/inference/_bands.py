"""Posterior bands of what a fitted noise model predicts, beside what was measured.

- **Allan deviation**: the measured overlapping ADEV with its classical chi-square bars, and
  two posterior bands. The darker one is the spread over posterior draws of the model's
  *exact* Allan deviation (NoiseModel.allan_variance, closed form at every tau): the
  uncertainty of the parameters alone. The lighter one is the posterior predictive band of
  the *measured* ADEV: each draw's exact Allan variance times a chi-square variate with the
  same equivalent degrees of freedom as the classical bars (Greenhall), so it adds the
  estimator's scatter. Both pointwise, 90 %. This is exact for the model's mean and as good
  as the classical bars for the scatter, at no simulation cost (simulating a recording per
  draw would cost seconds per channel and add nothing the chi-square law does not carry).
- **Spectrum**: the binned periodogram of the increments that the Whittle likelihood fits
  (bins of 2 % relative width), shown as the amplitude spectral density of the samples
  (divided by |1 - e^{-2 pi i f / fs}|^2 fs, two-sided, so white noise reads N), against the
  expected periodogram of posterior draws (the tapered, debiased expectation the likelihood
  uses) and its predictive band (a bin's mean of k ordinates is Gamma(k) / k times it).
"""

from dataclasses import asdict, dataclass

import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from ..models._whittle import expected_power
from ._noise_posterior import NoisePosterior, noise_model

BAND_LEVEL = 0.90
BAND_DRAWS = 400


@dataclass(frozen=True)
class AllanBand:
    """Posterior bands of the Allan deviation (:func:`allan_band`), pointwise at ``level``:
    at the measured taus and on a fine grid (``fine_*``). ``expected_*``: quantiles over draws
    of the model's exact deviation; ``predictive_*``: of the deviation a recording like this
    one would measure."""

    level: float
    n_draws: int
    tau_s: np.ndarray
    predictive_low: np.ndarray
    predictive_high: np.ndarray
    expected_low: np.ndarray
    expected_median: np.ndarray
    expected_high: np.ndarray
    fine_tau_s: np.ndarray
    fine_expected_low: np.ndarray
    fine_expected_median: np.ndarray
    fine_expected_high: np.ndarray

    def as_dict(self, unit: str) -> dict:
        """The band as the report's JSON holds it, with the channel's ``unit``."""
        return {**asdict(self), "unit": unit}


@dataclass(frozen=True)
class SpectrumBand:
    """The binned periodogram the likelihood fits and the model's expected periodogram over
    posterior draws (:func:`spectrum_band`), as two-sided amplitude spectral densities of the
    samples, pointwise at ``level``."""

    level: float
    frequency_hz: np.ndarray
    frequencies_per_bin: np.ndarray
    measured_asd: np.ndarray
    expected_median: np.ndarray
    expected_low: np.ndarray
    expected_high: np.ndarray
    predictive_low: np.ndarray
    predictive_high: np.ndarray

    def as_dict(self, unit: str) -> dict:
        """The band as the report's JSON holds it, with the channel's ``unit`` (the density's:
        unit/sqrt(Hz))."""
        return {**asdict(self), "unit": unit}


def draw_subset(fit: NoisePosterior, count: int, seed: int) -> dict[str, np.ndarray]:
    """The same ``count`` joint posterior draws of every parameter, flattened."""
    flat = {name: np.asarray(value, dtype=float).reshape(-1) for name, value in fit.draws.items()}
    total = next(iter(flat.values())).size
    rng = np.random.default_rng(seed)
    index = np.sort(rng.choice(total, size=min(count, total), replace=False))
    return {name: value[index] for name, value in flat.items()}


def model_allan_deviation(fit: NoisePosterior, draws: dict[str, np.ndarray], tau) -> np.ndarray:
    """(draws, taus): the exact Allan deviation of the noise model for each posterior draw
    (all draws at once; one by one through a low-pass filter, whose shape is numbers)."""
    tau = np.asarray(tau, dtype=float)
    if fit.problem.shape is not None:
        variance = np.stack([np.asarray(m.allan_variance(tau)) for m in fit.models(draws)])
    else:
        batch = {name: jnp.asarray(draws[name])[:, None] for name in fit.problem.parameters}
        model = noise_model(fit.problem, batch)
        variance = np.asarray(model.allan_variance(jnp.asarray(tau)[None, :]))
    return np.sqrt(np.maximum(variance, 0.0))


def allan_band(
    fit: NoisePosterior,
    allan,
    *,
    draws: int = BAND_DRAWS,
    level: float = BAND_LEVEL,
    seed: int = 0,
) -> AllanBand:
    """Posterior bands of the Allan deviation at the measured taus and on a fine grid.

    ``expected_*``: quantiles over draws of the model's exact ADEV (parameter uncertainty);
    ``predictive_*``: quantiles of the ADEV a recording like this one would measure (each
    draw's exact Allan variance times chi-square(edf) / edf, edf as for the classical bars).
    """
    sample = draw_subset(fit, draws, seed)
    tau = np.asarray(allan.tau, dtype=float)
    usable = np.isfinite(allan.deviation) & (tau > 0)
    tau = tau[usable]
    low_q, high_q = (1 - level) / 2, (1 + level) / 2
    fine = np.geomspace(tau.min(), tau.max(), 80) if tau.size else tau
    expected_fine = model_allan_deviation(fit, sample, fine)
    expected = model_allan_deviation(fit, sample, tau)
    edf = np.asarray(allan.edf, dtype=float)[usable]
    fallback = np.maximum(np.asarray(allan.n, dtype=float)[usable], 1.0)
    edf = np.where(np.isfinite(edf) & (edf > 0), edf, fallback)
    rng = np.random.default_rng(seed + 1)
    scatter = rng.chisquare(edf[None, :], size=expected.shape) / edf[None, :]
    predictive = expected * np.sqrt(scatter)
    return AllanBand(
        level=level,
        n_draws=int(expected.shape[0]),
        tau_s=tau,
        predictive_low=np.quantile(predictive, low_q, axis=0),
        predictive_high=np.quantile(predictive, high_q, axis=0),
        expected_low=np.quantile(expected, low_q, axis=0),
        expected_median=np.quantile(expected, 0.5, axis=0),
        expected_high=np.quantile(expected, high_q, axis=0),
        fine_tau_s=fine,
        fine_expected_low=np.quantile(expected_fine, low_q, axis=0),
        fine_expected_median=np.quantile(expected_fine, 0.5, axis=0),
        fine_expected_high=np.quantile(expected_fine, high_q, axis=0),
    )


def spectrum_band(
    fit: NoisePosterior, *, draws: int = BAND_DRAWS, level: float = BAND_LEVEL, seed: int = 0
) -> SpectrumBand:
    """The binned periodogram the likelihood fits and the model's expected periodogram, as
    two-sided amplitude spectral densities of the samples (white noise reads N)."""
    spectral = fit.problem.spectral
    rate = spectral.rate_hz
    sample = draw_subset(fit, draws, seed)
    count = np.asarray(spectral.count, dtype=float)
    expected = (
        np.stack(  # (draws, bins): the mean expected periodogram over each bin
            [
                expected_power(spectral, *model.whittle_weights(spectral))
                for model in fit.models(sample)
            ]
        )
        / count
    )
    effective = count * np.asarray(spectral.weight, dtype=float)
    rng = np.random.default_rng(seed + 2)
    predictive = expected * rng.gamma(effective, 1.0 / effective, size=expected.shape)
    frequency = np.asarray(spectral.frequency_hz, dtype=float)
    # Periodogram of the increments -> pseudo-PSD of the samples, per Hz, two-sided.
    to_samples = 1.0 / (4 * np.sin(np.pi * frequency / rate) ** 2 * rate)
    measured = np.asarray(spectral.power, dtype=float) / count
    order = np.argsort(frequency, kind="stable")
    low_q, high_q = (1 - level) / 2, (1 + level) / 2

    def asd(values):
        return np.sqrt(np.maximum(values * to_samples, 0.0))[..., order]

    return SpectrumBand(
        level=level,
        frequency_hz=frequency[order],
        frequencies_per_bin=count[order],
        measured_asd=asd(measured),
        expected_median=np.quantile(asd(expected), 0.5, axis=0),
        expected_low=np.quantile(asd(expected), low_q, axis=0),
        expected_high=np.quantile(asd(expected), high_q, axis=0),
        predictive_low=np.quantile(asd(predictive), low_q, axis=0),
        predictive_high=np.quantile(asd(predictive), high_q, axis=0),
    )
