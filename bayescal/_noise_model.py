"""The stationary noise of one static IMU channel, as one model object.

Terms (IEEE Std 952 / 1554, ../shared/DESIGN.md), for a rate signal in unit U sampled at fs:

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

The output filter is not an IEEE 952 term: it is the digital low-pass most MEMS parts apply
before decimating (the ADIS16405's output, for one, has a lag-1 autocorrelation of 0.17),
which bends the white part of the spectrum and which, left out, a model explains with flicker
or quantization.

Sampling: each sample is the average rate over its sample period (the integrated angle or
velocity increment divided by the period, as IMUs deliver it). With this sampling the Allan
variances of the table in DESIGN.md hold exactly at every tau = m / fs, and the spectra of
the samples are the aliased sums fs sum_k S((nu + k) fs) sinc^2(pi (nu + k)), which have
closed forms (nu in cycles per sample). The record starts at t = 0 with the random walk and
the flicker at zero, so ``bias`` is the expected reading at the start: the turn-on bias.
"""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.special import zeta

# The stationary-increment components of the spectrum, each a fixed shape times a weight
# (:func:`component_weights`): the output filter splits white noise into two.
SPECTRAL_COMPONENTS = (
    "white",
    "white_lag",
    "bias_instability",
    "rate_random_walk",
    "quantization",
)


def component_weights(N=0.0, B=0.0, K=0.0, Q=0.0, F=0.0):
    """Weights of :data:`SPECTRAL_COMPONENTS` for the given parameters (arrays broadcast):
    white noise through (a + b z^-1), a = 1 / (1 + F), b = F / (1 + F), has variance weight
    a^2 + b^2 and lag-one weight a b."""
    a, b = 1.0 / (1.0 + F), F / (1.0 + F)
    weights = (N**2 * (a * a + b * b), N**2 * a * b, B**2, K**2, Q**2)
    return jnp.stack(jnp.broadcast_arrays(*weights), axis=-1)


def _t2_log(t):
    """t^2 log|t|, zero at zero: the kernel of flicker's covariances."""
    t = np.asarray(t, dtype=float)
    safe = np.where(t == 0, 1.0, np.abs(t))
    return t * t * np.log(safe)


def _t2_log_fourth_difference(t):
    """Fourth central difference of t^2 log|t| at t >= 0. Beyond t = 20 the direct
    difference of numbers near t^2 log t loses every digit, and the expansion
    delta^4 = 16 sinh^4(D/2) = D^4 + D^6/6 + D^8/80 + D^10/1779 + ... gives
    -2/t^2 - 2/t^4 - 3/t^6 - (17/3)/t^8 to better than 1e-9 relative."""
    t = np.asarray(t, dtype=float)
    result = np.empty_like(t)
    far = t >= 20
    inverse_square = t[far] ** -2.0
    result[far] = -inverse_square * (
        2 + inverse_square * (2 + inverse_square * (3 + inverse_square * 17 / 3))
    )
    near = t[~far]
    result[~far] = (
        _t2_log(near + 2)
        - 4 * _t2_log(near + 1)
        + 6 * _t2_log(near)
        - 4 * _t2_log(near - 1)
        + _t2_log(near - 2)
    )
    return result


def flicker_increment_shape(nu):
    """Two-sided PSD of the increments of sampled flicker noise with B = 1, per cycle/sample.

    (1 / (2 pi^3)) sin^2(pi nu) [zeta(3, nu) + zeta(3, 1 - nu)] is the aliased, period-averaged
    spectrum of B^2 / (2 pi |f|); differencing multiplies it by 4 sin^2(pi nu). 0 < nu < 1.
    """
    sin2 = jnp.sin(jnp.pi * nu) ** 2
    return 4 * sin2 * sin2 * (zeta(3.0, nu) + zeta(3.0, 1.0 - nu)) / (2 * jnp.pi**3)


def increment_spectrum_shapes(nu, rate_hz):
    """Two-sided PSDs of the sample increments d_k = y_{k+1} - y_k, per unit parameter^2.

    Returns a dict term -> array over ``nu`` (cycles per sample, 0 < nu <= 1/2); the PSD of
    the increments is sum over terms of parameter^2 * shape.
    """
    period = 1.0 / rate_hz
    sin2 = jnp.sin(jnp.pi * nu) ** 2
    return {
        "white": 4 * sin2 * rate_hz,
        "white_lag": 8 * sin2 * jnp.cos(2 * jnp.pi * nu) * rate_hz,
        "bias_instability": flicker_increment_shape(nu),
        "rate_random_walk": period * (2 + jnp.cos(2 * jnp.pi * nu)) / 3,
        "quantization": 16 * sin2 * sin2 * rate_hz**2,
    }


def increment_autocovariance_shapes(lags, rate_hz):
    """Autocovariances of the increments at integer ``lags``, per unit parameter^2 (NumPy).

    The Fourier pairs of :func:`increment_spectrum_shapes`: white noise (and its filtered
    lag-one part), rate random walk and quantization give moving averages of order 1 (2),
    1 and 2; flicker gives
    (1 / 2 pi) times the fourth central difference of t^2 log|t| (its generalized
    covariance is -(B^2 / pi) log|t|; r(0) = (4 ln 2 / pi) B^2, twice its Allan variance).
    """
    lags = np.abs(np.asarray(lags, dtype=float))
    period = 1.0 / rate_hz

    def moving_average(weights):
        return sum(weight * (lags == lag) for lag, weight in enumerate(weights))

    return {
        "white": rate_hz * moving_average((2.0, -1.0)),
        "white_lag": rate_hz * moving_average((-2.0, 2.0, -1.0)),
        "bias_instability": _t2_log_fourth_difference(lags) / (2 * np.pi),
        "rate_random_walk": period * moving_average((2 / 3, 1 / 6)),
        "quantization": rate_hz**2 * moving_average((6.0, -4.0, 1.0)),
    }


class NoiseModel(eqx.Module):
    """Bias plus the noise terms of a static channel; parameters in the channel's unit U.

    A parameter of zero leaves its term out.
    """

    rate_hz: float = eqx.field(static=True)
    bias: float | jax.Array = 0.0
    N: float | jax.Array = 0.0
    B: float | jax.Array = 0.0
    K: float | jax.Array = 0.0
    Q: float | jax.Array = 0.0
    R: float | jax.Array = 0.0
    F: float | jax.Array = 0.0

    def __check_init__(self):
        if not self.rate_hz > 0:
            raise ValueError(f"rate_hz={self.rate_hz!r} must be a positive sample rate")
        if isinstance(self.F, (int, float)) and not -1 < self.F < 1:
            raise ValueError(f"F={self.F!r}: the output filter coefficient lies in (-1, 1)")

    def allan_variance(self, tau):
        """Allan variance at averaging times ``tau`` (s): the DESIGN.md table, exact here;
        the output filter adds 3 N^2 b (b - 1) / (fs tau^2), b = F / (1 + F)."""
        tau = jnp.asarray(tau, dtype=float)
        lag = self.F / (1.0 + self.F)
        return (
            3 * self.Q**2 / tau**2
            + self.N**2 / tau
            + 3 * self.N**2 * lag * (lag - 1) / (self.rate_hz * tau**2)
            + 2 * math.log(2) / math.pi * self.B**2
            + self.K**2 * tau / 3
            + self.R**2 * tau**2 / 2
        )

    def simulate(self, key: jax.Array, n: int) -> jax.Array:
        """``n`` samples of the channel; the same ``key`` gives the same samples."""
        period = 1.0 / self.rate_hz
        white_key, walk_key, bridge_key, flicker_key, quant_key = jax.random.split(key, 5)
        white = jax.random.normal(white_key, (n + 1,))
        white = (white[1:] + self.F * white[:-1]) / (1.0 + self.F)
        y = self.bias + self.N * math.sqrt(self.rate_hz) * white
        if _present(self.K):
            # Rate random walk: the average of a Brownian path over a period is its value at
            # the period's start plus K sqrt(period) (z/2 + u/sqrt(12)), with z the step and u
            # the Brownian bridge's part.
            steps = jax.random.normal(walk_key, (n,))
            start = jnp.concatenate((jnp.zeros(1), jnp.cumsum(steps)[:-1]))
            bridge = jax.random.normal(bridge_key, (n,))
            y = y + self.K * math.sqrt(period) * (start + steps / 2 + bridge / math.sqrt(12.0))
        if _present(self.B):
            y = y + self.B * _flicker_path(flicker_key, n)
        if _present(self.Q):
            # Quantization of the integrated signal: uniform error of variance Q^2 per sample.
            phase_error = jax.random.uniform(quant_key, (n + 1,), minval=-0.5, maxval=0.5)
            y = y + self.Q * math.sqrt(12.0) * jnp.diff(phase_error) / period
        if _present(self.R):
            y = y + self.R * period * (jnp.arange(n) + 0.5)
        return y


def _present(parameter) -> bool:
    """False only for a term switched off by a literal zero (traced values always count)."""
    return not (isinstance(parameter, (int, float)) and parameter == 0)


def _flicker_path(key, n):
    """Sampled flicker noise with B = 1, starting at zero: the increments are drawn by
    spectral synthesis on a circulant twice the record's length, then summed."""
    size = 1 << max(4, (2 * n - 1).bit_length())
    nu = jnp.arange(1, size // 2 + 1) / size
    amplitude = jnp.sqrt(flicker_increment_shape(nu) * size)
    real_key, imag_key, nyquist_key = jax.random.split(key, 3)
    half = size // 2
    spectrum = jax.random.normal(real_key, (half,)) + 1j * jax.random.normal(imag_key, (half,))
    spectrum = spectrum * amplitude / math.sqrt(2.0)
    # The Nyquist bin of a real series is real; its variance is the full PSD there.
    spectrum = spectrum.at[-1].set(jax.random.normal(nyquist_key, ()) * amplitude[-1])
    increments = jnp.fft.irfft(jnp.concatenate((jnp.zeros(1), spectrum)), n=size)[: n - 1]
    return jnp.concatenate((jnp.zeros(1), jnp.cumsum(increments)))
