"""The stationary noise of one static IMU channel, as one model object.

Terms (IEEE Std 952 / 1554, ../shared/DESIGN.md), for a rate signal in unit U sampled at fs,
each one class in :mod:`bayescal.models.effects`:

==================  =========  =============  ===========================================
term                parameter  unit           two-sided PSD of the continuous rate S(f)
==================  =========  =============  ===========================================
white noise         N          U/sqrt(Hz)     N^2
bias instability    B          U              B^2 / (2 pi |f|)
rate random walk    K          U*sqrt(Hz)     K^2 / (2 pi f)^2
quantization        Q          U*s            white phase (angle) noise of variance Q^2
rate ramp           R          U/s            deterministic R t
output filter       F          1              the white noise leaves the sensor through
                                              (1 + F z^-1) / (1 + F): unit gain at low
                                              frequency (N stays the noise density the
                                              Allan curve reads), less power near Nyquist
==================  =========  =============  ===========================================

Sampling: each sample is the average rate over its sample period (the integrated angle or
velocity increment divided by the period, as IMUs deliver it). With this sampling the Allan
variances of the table in DESIGN.md hold exactly at every tau = m / fs, and the spectra of
the samples are the aliased sums fs sum_k S((nu + k) fs) sinc^2(pi (nu + k)), which have
closed forms (nu in cycles per sample). The record starts at t = 0 with the random walk and
the flicker at zero, so ``bias`` is the expected reading at the start: the turn-on bias.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.stats import norm

from .._x64 import require_x64  # float64 before any JAX array
from ._components import SPECTRAL_TERMS, component_weights
from ._level import bias_given_noise, level_summary
from ._whittle import spectral_summary, whittle_log_likelihood
from .effects.bias_instability import BiasInstability
from .effects.gauss_markov import GaussMarkov
from .effects.output_filter import LOWPASS_UNITS, OutputFilter
from .effects.quantization import Quantization
from .effects.rate_ramp import RateRamp
from .effects.rate_random_walk import RateRandomWalk
from .effects.white import White

_TERM_OF_PARAMETER = {term.parameter: term for term in (*SPECTRAL_TERMS, RateRamp, GaussMarkov)}


def parameter_unit(parameter: str, channel_unit: str) -> str:
    """Unit of a noise parameter (Q, N, B, K, R, F, sigma_gm, or the bias) for a channel in
    ``channel_unit`` (IEEE Std 952; ASCII, e.g. ``deg/s/sqrt(Hz)``).

    Raises
    ------
    ValueError
        An unknown parameter.
    """
    if parameter == "bias":
        return channel_unit
    if parameter in LOWPASS_UNITS:
        return LOWPASS_UNITS[parameter]
    if parameter not in _TERM_OF_PARAMETER:
        raise ValueError(
            f"unknown noise parameter {parameter!r}; expected bias or one of "
            f"{', '.join((*_TERM_OF_PARAMETER, *LOWPASS_UNITS))}"
        )
    return _TERM_OF_PARAMETER[parameter].unit(channel_unit)


def _present(parameter) -> bool:
    """False only for a term switched off by a literal zero (traced values always count)."""
    return not (isinstance(parameter, (int, float)) and parameter == 0)


class NoiseModel(eqx.Module):
    """Bias plus the noise terms of a static channel; one object whose simulator, Allan
    variance, spectrum and likelihood share its parameters (in the channel's unit U).

    A parameter of zero leaves its term out. Parameters may be JAX arrays (a batch of draws
    broadcasts through :meth:`allan_variance` and :meth:`psd`).

    Parameters
    ----------
    rate_hz : float
        Sample rate, Hz.
    bias : float
        Turn-on bias: the expected reading at the first sample, U.
    N : float
        White noise density (angle / velocity random walk), U/√Hz.
    B : float
        Bias instability (flicker), U.
    K : float
        Rate random walk, U·√Hz.
    Q : float
        Quantization (white angle noise), U·s.
    R : float
        Rate ramp, U/s.
    F : float
        One-tap output filter coefficient in (-1, 1), dimensionless.
    lowpass : OutputFilter, optional
        The sensor's low-pass output filter (shape "decimation", "butterworth" or "biquad"),
        unit gain at zero frequency: it shapes the white noise, so N stays the low-frequency
        density.
    lsb : float
        The output's resolution, U: the samples are rounded to multiples of it (zero: not
        rounded).

    Examples
    --------
    >>> import numpy as np
    >>> import bayescal as bc
    >>> model = bc.NoiseModel(rate_hz=100.0, bias=0.4, N=0.0035, K=4e-5)
    >>> y = model.simulate(360_000, seed=0)
    >>> y.shape
    (360000,)
    >>> float(np.sqrt(model.allan_variance(1.0)))  # ADEV at 1 s, deg/s
    0.0035...
    """

    rate_hz: float = eqx.field(static=True)
    bias: float | jax.Array = 0.0
    N: float | jax.Array = 0.0
    B: float | jax.Array = 0.0
    K: float | jax.Array = 0.0
    Q: float | jax.Array = 0.0
    R: float | jax.Array = 0.0
    F: float | jax.Array = 0.0
    lowpass: OutputFilter | None = None
    lsb: float | jax.Array = 0.0

    def __check_init__(self):
        if not self.rate_hz > 0:
            raise ValueError(f"rate_hz={self.rate_hz!r} must be a positive sample rate")
        if isinstance(self.F, (int, float)) and not -1 < self.F < 1:
            raise ValueError(f"F={self.F!r}: the output filter coefficient lies in (-1, 1)")
        if self.lowpass is not None and (self.lowpass.shape == "one_tap" or _present(self.F)):
            raise ValueError(
                "lowpass: a decimation, Butterworth or biquad OutputFilter, and F = 0 beside it "
                "(one output filter shape at a time)"
            )
        if isinstance(self.lsb, (int, float)) and not self.lsb >= 0:
            raise ValueError(f"lsb={self.lsb!r}: the output's resolution is zero or positive")

    @property
    def rounding_variance(self) -> float:
        """Variance of the rounding error per sample, LSB^2 / 12, U^2 (zero without an LSB):
        white, beside the filtered noise (Widrow's additive model, exact to within
        exp(-2 pi^2 sd^2 / LSB^2) of the noise's sd; within 2e-4 for an LSB of 1.5 sd)."""
        return self.lsb**2 / 12.0

    def increment_weights(self):
        """Weights of the spectral components of the increments
        (:func:`~bayescal.models._components.component_weights`), the rounding's floor on the
        white one.

        Returns
        -------
        jax.Array
            One weight per spectral component of the increments, U^2 (the component's
            variance per sample).
        """
        weights = component_weights(self.N, self.B, self.K, self.Q, self.F)
        return weights.at[..., 0].add(self.rounding_variance / self.rate_hz)

    def whittle_weights(self, nu):
        """(variances, filtered) for :func:`~bayescal.models._whittle.whittle_log_likelihood`
        at nodes ``nu`` (cycles per sample): without a low-pass, :meth:`increment_weights` and
        None; with one, the weights the filter does not shape and (|H|^2 at ``nu``, the
        weights of the white noise's two components it shapes).

        Parameters
        ----------
        nu : array_like
            Frequencies, cycles per sample (0 < nu <= 1/2).

        Returns
        -------
        variances : jax.Array
            The weights the low-pass does not shape, U^2.
        filtered : tuple of jax.Array or None
            None without a low-pass; else (|H|^2 at ``nu``, the white noise's two weights).
        """
        weights = self.increment_weights()
        if self.lowpass is None:
            return weights, None
        white = component_weights(self.N, F=self.F)[..., :2]
        rest = weights.at[..., 0].set(self.rounding_variance / self.rate_hz).at[..., 1].set(0.0)
        return rest, (self.lowpass.gain(nu, self.rate_hz), white)

    def increment_autocovariance(self, lags) -> np.ndarray:
        """Autocovariance of the increments y_{k+1} - y_k at integer ``lags``, U^2: each
        component's closed form, and the low-pass's change to the white noise's by numerical
        integration of its spectrum (8192 midpoints on (0, 1/2)).

        Parameters
        ----------
        lags : array_like of int
            Lags, samples (0 is the variance).

        Returns
        -------
        numpy.ndarray
            The autocovariance at each lag, U^2.
        """
        lags = np.asarray(lags, dtype=float)
        weights = np.asarray(self.increment_weights())
        covariance = sum(
            weight * term.autocovariance(lags, self.rate_hz)
            for weight, term in zip(weights, SPECTRAL_TERMS, strict=True)
        )
        nu = (np.arange(8192) + 0.5) / 16384
        _, shaping = self.whittle_weights(nu)
        if shaping is not None:
            gain, white = (np.asarray(part) for part in shaping)
            spectrum = sum(
                w * np.asarray(t.spectrum(nu, self.rate_hz))
                for w, t in zip(white, SPECTRAL_TERMS[:2], strict=True)
            )
            cosine = np.cos(2 * np.pi * np.outer(lags, nu))
            covariance = covariance + 2 * cosine @ (spectrum * (gain - 1.0)) / 16384
        return covariance

    def allan_variance(self, tau):
        """Allan variance at averaging times ``tau`` (s), U^2: the sum of each term's (the
        DESIGN.md table, exact for period-averaged samples), the white noise's through the
        low-pass when there is one, and the rounding's, LSB^2 / (12 fs tau).

        Parameters
        ----------
        tau : array_like
            Averaging times, s (exact at multiples of the sample period).

        Returns
        -------
        jax.Array
            The Allan variance at each tau, U^2 (its square root is the Allan deviation).

        Examples
        --------
        >>> import numpy as np
        >>> import bayescal as bc
        >>> model = bc.NoiseModel(rate_hz=100.0, N=0.01, K=1e-4)
        >>> np.sqrt(model.allan_variance(np.array([1.0, 3.0]))).round(5)  # ADEV, U
        array([0.01   , 0.00577])
        """
        tau = jnp.asarray(tau, dtype=float)
        white = (
            White.allan_variance(tau, self.N)
            if self.lowpass is None
            else self.lowpass.shaped_allan_variance(tau, self.N, self.rate_hz)
        )
        return (
            Quantization.allan_variance(tau, self.Q)
            + white
            + self.rounding_variance / (tau * self.rate_hz)
            + OutputFilter.allan_variance(tau, self.N, self.F, self.rate_hz)
            + BiasInstability.allan_variance(tau, self.B)
            + RateRandomWalk.allan_variance(tau, self.K)
            + RateRamp.allan_variance(tau, self.R)
        )

    def psd(self, f):
        """Two-sided power spectral density of the samples at ``f`` (Hz, 0 < f <= fs/2),
        U^2/Hz: white noise reads N^2. The increments' spectrum divided by the differencing
        filter's gain |1 - e^{-2 pi i f / fs}|^2 = 4 sin^2(pi f / fs), per Hz; the rate random
        walk and flicker diverge at zero frequency, the ramp (deterministic) is left out. The
        low-pass multiplies the white noise's; the rounding adds LSB^2 / (12 fs).

        Parameters
        ----------
        f : array_like
            Frequencies, Hz (0 < f <= rate_hz / 2).

        Returns
        -------
        jax.Array
            The density at each frequency, U^2/Hz.

        Examples
        --------
        >>> import bayescal as bc
        >>> float(bc.NoiseModel(rate_hz=100.0, N=0.01).psd(10.0))  # N^2
        0.0001
        """
        nu = jnp.asarray(f, dtype=float) / self.rate_hz
        weights = component_weights(self.N, self.B, self.K, self.Q, self.F)
        shapes = jnp.stack([term.spectrum(nu, self.rate_hz) for term in SPECTRAL_TERMS], -1)
        parts = weights * shapes
        if self.lowpass is not None:  # the white noise's two components through the filter
            gain = self.lowpass.gain(nu, self.rate_hz)[..., None]
            parts = parts.at[..., :2].multiply(gain)
        increments = jnp.sum(parts, axis=-1)
        return increments / (4 * jnp.sin(jnp.pi * nu) ** 2 * self.rate_hz) + (
            self.rounding_variance / self.rate_hz
        )

    def sample(self, key: jax.Array, n: int) -> jax.Array:
        """``n`` samples of the channel as a JAX array (traceable: ``jax.vmap`` over keys
        gives many records); :meth:`simulate` is the NumPy form.

        Parameters
        ----------
        key : jax.Array
            A JAX PRNG key.
        n : int
            Number of samples.

        Returns
        -------
        jax.Array
            The samples, U, each the average rate over its period, starting at t = 0.
        """
        # The order of the draws is fixed: the same key gives the same record in every
        # release.
        white_key, walk_key, bridge_key, flicker_key, quant_key = jax.random.split(key, 5)
        if self.lowpass is None:
            y = self.bias + White.sample(white_key, n, self.rate_hz, self.N, self.F)
        else:
            white = White.sample(white_key, 2 * n, self.rate_hz, self.N)
            y = self.bias + self.lowpass.apply(white, self.rate_hz)[:n]
        if _present(self.K):
            y = y + RateRandomWalk.sample(walk_key, bridge_key, n, self.rate_hz, self.K)
        if _present(self.B):
            y = y + self.B * BiasInstability.sample(flicker_key, n)
        if _present(self.Q):
            y = y + Quantization.sample(quant_key, n, self.rate_hz, self.Q)
        if _present(self.R):
            y = y + RateRamp.sample(n, self.rate_hz, self.R)
        if _present(self.lsb):
            y = self.lsb * jnp.round(y / self.lsb)
        return y

    def simulate(self, n: int, seed: int | jax.Array = 0) -> np.ndarray:
        """``n`` samples of the channel, U.

        Parameters
        ----------
        n : int
            Number of samples.
        seed : int or JAX PRNG key
            The same seed gives the same samples.

        Returns
        -------
        numpy.ndarray
            The samples, each the average rate over its period, starting at t = 0.

        Raises
        ------
        InputError
            JAX's 64-bit mode was turned off (bayescal turns it on for the process).
        """
        require_x64()
        key = jax.random.PRNGKey(seed) if isinstance(seed, (int, np.integer)) else seed
        return np.asarray(self.sample(key, n))

    def log_likelihood(self, y) -> float:
        """Log-likelihood of a record ``y`` (U; NaN marks missing samples): the debiased,
        binned Whittle likelihood of its increments (the likelihood every noise fit of
        bayescal uses, :mod:`bayescal.models._whittle`; the low-pass and the rounding as in
        :meth:`psd`), plus the exact Gaussian log density
        of its level — the generalised-least-squares estimate of the turn-on bias from block
        means given the noise (:mod:`bayescal.models._level`) — at :attr:`bias`.

        Parameters
        ----------
        y : array_like
            The record, U, sampled at ``rate_hz``; NaN marks a missing sample.

        Returns
        -------
        float
            The log-likelihood, nats.

        Examples
        --------
        >>> import bayescal as bc
        >>> truth = bc.NoiseModel(rate_hz=100.0, bias=0.4, N=0.004)
        >>> y = truth.simulate(2**14, seed=1)
        >>> other = bc.NoiseModel(rate_hz=100.0, bias=0.4, N=0.005)
        >>> bool(truth.log_likelihood(y) > other.log_likelihood(y))
        True
        """
        values = np.asarray(y, dtype=float)
        summary = spectral_summary(values, self.rate_hz)
        variances, filtered = self.whittle_weights(summary.node_frequency)
        increments = whittle_log_likelihood(summary, variances, self.R, filtered=filtered)
        weights = self.increment_weights()
        mean, variance = bias_given_noise(level_summary(values, self.rate_hz), weights, self.R)
        level = norm.logpdf(mean, loc=self.bias, scale=jnp.sqrt(variance))
        return float(jnp.sum(increments) + level)
