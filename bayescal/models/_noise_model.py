"""The stationary noise of one static IMU channel, as one model object.

Terms (IEEE Std 952 / 1554, ../shared/DESIGN.md), for a rate signal in unit U sampled at fs,
each one class in :mod:`bayescal.models.effects`, registered in
:data:`bayescal.models._terms.NOISE_TERMS`: the model reads them from there, and ``bayescal
terms`` lists them all. IEEE Std 952's are:

==================  =========  =============  ===========================================
term                parameter  unit           two-sided PSD of the continuous rate S(f)
==================  =========  =============  ===========================================
white noise         N          U/sqrt(Hz)     N^2
bias instability    B          U              B^2 / (2 pi |f|)
rate random walk    K          U*sqrt(Hz)     K^2 / (2 pi f)^2
quantization        Q          U*s            white phase (angle) noise of variance Q^2
rate ramp           R          U/s            deterministic R t
output filter       F          1              the white noise leaves the sensor through
                                              (1 + F z^-1) / (1 + F), F in (0, 1): unit
                                              gain at low frequency (N stays the noise
                                              density the Allan curve reads), less power
                                              near Nyquist (or a low-pass shape instead)
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
from ._components import Components
from ._level import bias_given_noise, level_summary
from ._terms import NOISE_TERMS, PARAMETERS
from ._whittle import spectral_summary, whittle_log_likelihood
from .effects._parameter import Context
from .effects.white import White


def _present(value) -> bool:
    """False only for a term switched off by a literal zero (traced values always count)."""
    return not (isinstance(value, (int, float)) and value == 0)


class NoiseModel(eqx.Module):
    """Bias plus the noise terms of a static channel; one object whose simulator, Allan
    variance, spectrum and likelihood share its parameters (in the channel's unit U).

    The parameters are those of the registered terms, by name (module docstring; ``N``,
    ``B``, ``K``, ``Q``, ``R``, ``F``, a low-pass shape's ``filter_...``; ``bayescal terms``
    lists them all); a term whose scale (its first parameter) is zero or absent is left
    out. Parameters may be JAX arrays (a batch of draws broadcasts through
    :meth:`allan_variance` and :meth:`psd`).

    Parameters
    ----------
    rate_hz : float
        Sample rate, Hz.
    bias : float
        Turn-on bias: the expected reading at the first sample, U.
    lsb : float
        The output's resolution, U: the samples are rounded to multiples of it (zero: not
        rounded).
    **parameters : float
        The noise parameters by name, each in its unit
        (:func:`~bayescal.models._terms.parameter_unit`): N (U/√Hz),
        B (U), K (U·√Hz), Q (U·s), R (U/s), F (one-tap output filter coefficient in (0, 1)),
        the other registered terms', or one low-pass shape's parameters (``filter_length``
        and ``filter_stages``; ``filter_cutoff``, ``filter_order`` and ``filter_warping``;
        ``filter_pole_k1`` ... ``filter_zero_k2``): it shapes the white noise with unit gain
        at zero frequency, so N stays the low-frequency density.

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
    bias: float | jax.Array
    values: dict
    """The noise parameters by name (only those given)."""
    lsb: float | jax.Array

    def __init__(self, rate_hz: float, bias=0.0, *, lsb=0.0, **parameters):
        unknown = [name for name in parameters if name not in PARAMETERS]
        if unknown:
            raise ValueError(
                f"NoiseModel: unknown parameter {unknown[0]!r}; the parameters are "
                f"{', '.join(PARAMETERS)}"
            )
        self.rate_hz, self.bias, self.lsb = rate_hz, bias, lsb
        self.values = dict(parameters)

    def __check_init__(self):
        if not self.rate_hz > 0:
            raise ValueError(f"rate_hz={self.rate_hz!r} must be a positive sample rate")
        if isinstance(self.lsb, (int, float)) and not self.lsb >= 0:
            raise ValueError(f"lsb={self.lsb!r}: the output's resolution is zero or positive")
        context = Context(self.rate_hz)
        for name, value in self.values.items():
            parameter = PARAMETERS[name]
            if isinstance(value, (int, float)) and value != 0 and parameter.span != "record":
                low, high = parameter.bounds(context)
                if not low < value < high:
                    raise ValueError(f"{name}={value!r}: it lies in ({low:g}, {high:g})")
        for term in self.terms:
            missing = [p.name for p in term.parameters if p.name not in self.values]
            if missing:
                raise ValueError(f"{term.name} needs {', '.join(missing)} too")
        shapes = [term.name for term in self.terms if term.filter_shape is not None]
        if len(shapes) > 1:
            raise ValueError(f"one output filter shape at a time ({', '.join(shapes)} given)")

    def __getattr__(self, name):
        # The parameters read as attributes (model.N), zero for a term left out.
        if name in PARAMETERS:
            return self.values.get(name, 0.0)
        raise AttributeError(f"'NoiseModel' object has no attribute {name!r}")

    @property
    def terms(self) -> tuple:
        """The terms the model holds (those whose scale is given and not zero), in the
        registry's order."""
        return tuple(
            term
            for term in NOISE_TERMS
            if term.parameters and _present(self.values.get(term.parameters[0].name, 0.0))
        )

    @property
    def _active(self) -> dict:
        """The parameters of the terms the model holds."""
        return {p.name: self.values[p.name] for term in self.terms for p in term.parameters}

    @property
    def lowpass(self):
        """The low-pass shape of the output filter (its term), or None."""
        shapes = [t for t in self.terms if t.filter_shape not in (None, "one_tap")]
        return shapes[0] if shapes else None

    @property
    def rounding_variance(self) -> float:
        """Variance of the rounding error per sample, LSB^2 / 12, U^2 (zero without an LSB):
        white, beside the filtered noise (Widrow's additive model, exact to within
        exp(-2 pi^2 sd^2 / LSB^2) of the noise's sd; within 2e-4 for an LSB of 1.5 sd)."""
        return self.lsb**2 / 12.0

    def whittle_weights(self, summary):
        """(variances, filtered) for :func:`~bayescal.models._whittle.whittle_log_likelihood`
        of ``summary``, aligned with its components: without a low-pass, every component's
        weight (the rounding's floor on the white one) and None; with one, the weights the
        filter does not shape and (|H|^2 at the summary's nodes, the weights it shapes).

        Parameters
        ----------
        summary : SpectralSummary
            A record's spectral summary (:func:`~bayescal.models._whittle.spectral_summary`)
            whose components hold the model's terms.

        Returns
        -------
        variances : jax.Array
            The weights the low-pass does not shape, U^2.
        filtered : tuple of jax.Array or None
            None without a low-pass; else (|H|^2 at the nodes, the shaped weights).
        """
        components = summary.components
        weights = components.weights(self._active)
        floor = self.rounding_variance / self.rate_hz
        if self.lowpass is None:
            return weights.at[..., components.white].add(floor), None
        shaped = summary.shaped
        gain = self.lowpass.gain(summary.node_frequency, self._active, self.rate_hz)
        rest = weights.at[..., shaped].set(0.0).at[..., components.white].set(floor)
        return rest, (gain, weights[..., shaped])

    def increment_autocovariance(self, lags) -> np.ndarray:
        """Autocovariance of the increments y_{k+1} - y_k at integer ``lags``, U^2: each
        term's closed form, the low-pass's change to the white noise's by numerical
        integration of its spectrum (8192 midpoints on (0, 1/2)), and the rounding's.

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
        values = self._active
        covariance = sum(
            np.asarray(term.increment_autocovariance(lags, values, self.rate_hz))
            for term in self.terms
        )
        covariance = covariance + self.rounding_variance / self.rate_hz * White.autocovariance(
            lags, self.rate_hz
        )
        if self.lowpass is not None:
            nu = (np.arange(8192) + 0.5) / 16384
            gain = np.asarray(self.lowpass.gain(nu, values, self.rate_hz))
            spectrum = sum(
                np.asarray(term.increment_spectrum(nu, values, self.rate_hz))
                for term in self.terms
                if term.filtered
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
        values, lowpass = self._active, self.lowpass
        total = self.rounding_variance / (tau * self.rate_hz)
        for term in self.terms:
            if term is White and lowpass is not None:
                total = total + lowpass.shaped_allan_variance(tau, values, self.rate_hz)
            else:
                total = total + term.allan_variance(tau, values, self.rate_hz)
        return total

    def allan_exponents(self, tau) -> list:
        """The power-law exponent alpha of S_y(f) of the term with the largest Allan variance
        at each ``tau`` (for the equivalent degrees of freedom of a check).

        Parameters
        ----------
        tau : array_like
            Averaging times, s.

        Returns
        -------
        list of int
            alpha at each tau (0: white, -1: flicker, -2: random walk, 2: white angle noise).
        """
        tau = np.asarray(tau, dtype=float)
        pairs = [
            pair
            for term in self.terms
            for pair in term.allan_exponents(tau, self._active, self.rate_hz)
        ]
        if not pairs:
            return [0] * tau.size
        exponents = np.array([alpha for alpha, _ in pairs])
        values = np.stack([np.broadcast_to(np.asarray(v), tau.shape) for _, v in pairs])
        return exponents[np.argmax(values, axis=0)].tolist()

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
        values, lowpass = self._active, self.lowpass
        increments = 0.0 * nu
        for term in self.terms:
            part = term.increment_spectrum(nu, values, self.rate_hz)
            if term.filtered and lowpass is not None:
                part = part * lowpass.gain(nu, values, self.rate_hz)
            increments = increments + part
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
        # Each term draws on its own streams of one split (NoiseTerm.streams): the same key
        # gives the same record in every release.
        count = 1 + max(stream for term in NOISE_TERMS for stream in term.streams)
        keys = jax.random.split(key, count)
        values, lowpass = self._active, self.lowpass
        y = self.bias + jnp.zeros(n)
        for term in self.terms:
            if term.filtered and lowpass is not None:
                part = lowpass.apply(
                    term.sample(keys, 2 * n, self.rate_hz, values), values, self.rate_hz
                )[:n]
            else:
                part = term.sample(keys, n, self.rate_hz, values)
            y = y + part
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
        :meth:`psd`), plus the exact Gaussian log density of its level — the
        generalised-least-squares estimate of the turn-on bias from block means given the
        noise (:mod:`bayescal.models._level`) — at :attr:`bias`.

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
        names = [term.name for term in self.terms]
        components = Components.of(names, Context(self.rate_hz, values.size / self.rate_hz))
        summary = spectral_summary(values, self.rate_hz, components=components)
        variances, filtered = self.whittle_weights(summary)
        ramp = self._active.get("R", 0.0)
        increments = whittle_log_likelihood(summary, variances, ramp, filtered=filtered)
        level = level_summary(values, self.rate_hz, components)
        weights = (
            components.weights(self._active)
            .at[..., components.white]
            .add(self.rounding_variance / self.rate_hz)
        )
        mean, variance = bias_given_noise(level, weights, ramp)
        return float(
            jnp.sum(increments) + norm.logpdf(mean, loc=self.bias, scale=jnp.sqrt(variance))
        )
