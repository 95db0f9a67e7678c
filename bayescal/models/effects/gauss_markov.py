"""First-order Gauss-Markov bias: exponentially correlated, with a correlation time."""

import math
from typing import ClassVar

import jax
import jax.numpy as jnp
import numpy as np

from ... import _x64  # noqa: F401  (float64 before any JAX array)
from ._base import TIME_CONSTANT_PENALTY, NoiseTerm
from ._parameter import Parameter

NODES_PER_DECADE = 8
"""Correlation times per decade at which the term's shape is computed exactly; between them
its weights interpolate (cubic, :func:`_interpolation_weights`)."""
PEAK_DEVIATION = 0.6174
"""The largest Allan deviation of a Gauss-Markov term per unit sigma, at tau = 1.89 tau_c
(the maximum of :meth:`GaussMarkov.allan_variance` over tau / tau_c)."""


def _one_period(x):
    """(1 - e^-x) / x, 1 at x = 0 (JAX; numpy inputs welcome)."""
    x = jnp.asarray(x, dtype=float)
    safe = jnp.where(x > 0, x, 1.0)
    return jnp.where(x > 0, -jnp.expm1(-safe) / safe, 1.0)


_SERIES_BELOW = 0.05
"""Below this the closed forms are summed as their Taylor series (they subtract numbers close
to 1; the series' first neglected term is below 1e-12 of the sum here)."""


def _integral_fraction(x):
    """(x - 1 + e^-x) / x^2: half the variance of the average of a unit-variance
    Ornstein-Uhlenbeck process over x correlation times."""
    x = jnp.asarray(x, dtype=float)
    series = 0.5 - x / 6 + x**2 / 24 - x**3 / 120 + x**4 / 720 - x**5 / 5040 + x**6 / 40320
    safe = jnp.where(x < _SERIES_BELOW, 1.0, x)
    return jnp.where(x < _SERIES_BELOW, series, (safe + jnp.expm1(-safe)) / safe**2)


@jax.jit
def _block_fractions(x):
    """:func:`_one_period` and :func:`_integral_fraction` of the blocks' lengths in
    correlation times, in one compiled call: a record's level summary takes them at every node
    of the grid, and each of their two dozen operations run outside a compiled function loads
    a kernel on a process's first call."""
    return _one_period(x), _integral_fraction(x)


def _lag_zero_excess(a):
    """r(0) - r(1) of :meth:`GaussMarkov.rate_autocovariance`: 2 (a - 1 + e^-a) / a^2 -
    ((1 - e^-a) / a)^2, its Taylor series for small a."""
    a = jnp.asarray(a, dtype=float)
    series = 2 * a / 3 - a**2 / 2 + 7 * a**3 / 30 - a**4 / 12 + 31 * a**5 / 1260 - a**6 / 160
    safe = jnp.where(a < _SERIES_BELOW, 1.0, a)
    direct = 2.0 * _integral_fraction(safe) - _one_period(safe) ** 2
    return jnp.where(a < _SERIES_BELOW, series, direct)


def _interpolation_weights(u, count: int):
    """(..., count): the Catmull-Rom weights of nodes 0..count-1 (node k at u = k - 1) at the
    fractional node index ``u`` (0 <= u <= count - 3): exact for a cubic in u, and the weights
    sum to one."""
    cell = jnp.clip(jnp.floor(u), 0, count - 4)
    t = u - cell
    t2, t3 = t * t, t * t * t
    parts = (
        (-t3 + 2 * t2 - t) / 2,
        (3 * t3 - 5 * t2 + 2) / 2,
        (-3 * t3 + 4 * t2 + t) / 2,
        (t3 - t2) / 2,
    )
    index = jnp.arange(count)
    return sum(part[..., None] * (index == (cell + k)[..., None]) for k, part in enumerate(parts))


class GaussMarkov(NoiseTerm):
    """An Ornstein-Uhlenbeck bias of variance sigma^2 (``gm_sigma``, the channel's unit) and
    correlation time tau_c (``gm_tau``, s), each sample its average over the sample period:
    it wanders but returns, a bump in the Allan deviation (its peak 0.617 sigma at tau =
    1.89 tau_c) and a Lorentzian spectrum — the first-order Markov bias of navigation
    filters (GMWM's staple).

    In the noise model both parameters are sampled: the shape of the increments' spectrum
    depends on tau_c, so the term's components are its exact shapes at correlation times
    spaced :data:`NODES_PER_DECADE` per decade from a sample period to the record's length
    (the range of ``gm_tau``), and its weights interpolate between them in log tau_c: the
    likelihood keeps exact expected periodograms at the nodes and stays linear in the
    weights. Discovery fixes tau_c by a search instead; an instance holds it
    (``time_constant_s``)."""

    name: ClassVar[str] = "gauss_markov"
    explanation: ClassVar[str] = (
        "The bias is exponentially correlated with a time constant: it wanders but returns, "
        "which leaves a bump in the Allan deviation and a Lorentzian spectrum."
    )
    located_by: ClassVar[str] = "allan_deviation"
    band: ClassVar[str] = "low"
    aliases: ClassVar[tuple[str, ...]] = ("gm", "markov", "first_order_markov")
    parameters: ClassVar[tuple[Parameter, ...]] = (
        Parameter(
            "gm_sigma",
            "Gauss-Markov sigma",
            time_power=0.0,
            datasheet=True,
        ),
        # Near flat in log tau_c over the record's range (logistic sd 1.8).
        Parameter(
            "gm_tau",
            "Gauss-Markov correlation time",
            time_power=None,
            unit="s",
            link="log_logit",
            span="record",
            prior=(0.0, 1.8),
        ),
    )
    streams: ClassVar[tuple[int, ...]] = (5,)
    long_memory: ClassVar[bool] = True
    time_constant_s: float = 1.0

    @property
    def searched(self) -> int:
        return 1

    def search_penalty(self, n_frequencies: int) -> float:
        return TIME_CONSTANT_PENALTY

    @classmethod
    def propose(cls, search, current):
        if current.spec.has(cls.name):
            return None
        # From a few samples up: a bias correlated over a fraction of a second is this
        # term's, not a filter's or flicker's.
        return search.search_time(
            lambda time_constant: current.spec.with_effect(cls(time_constant)),
            cls.name,
            shortest_s=0.0,
        )

    def describe(self, finding, posterior, search) -> dict:
        time_constant = search.profile_interval(finding.search)
        sigma = search.summarize(posterior.draws["gm_sigma"], posterior.units["gm_sigma"])
        return {
            "gm_sigma": search.widened(
                sigma, finding.search, "gm_sigma", time_constant, log_scale=True
            ),
            "gm_tau": time_constant,
        }

    @classmethod
    def components(cls, context) -> tuple:
        """Its shape at correlation times from one node below a sample period to one above the
        record's length, :data:`NODES_PER_DECADE` per decade."""
        step = math.log(10.0) / NODES_PER_DECADE
        count = math.ceil(math.log(context.duration_s * context.rate_hz) / step) + 3
        shortest = 1.0 / context.rate_hz
        return tuple(cls(shortest * math.exp((k - 1) * step)) for k in range(count))

    @classmethod
    def weights(cls, values, components):
        """sigma^2 times the interpolation weights of its nodes at log tau_c."""
        step = math.log(10.0) / NODES_PER_DECADE
        shortest = components[1].time_constant_s
        u = (jnp.log(values["gm_tau"]) - math.log(shortest)) / step
        return jnp.asarray(values["gm_sigma"] ** 2)[..., None] * _interpolation_weights(
            u, len(components)
        )

    @classmethod
    def increment_spectrum(cls, nu, values, rate_hz):
        """sigma^2 times the increments' spectrum at the correlation time ``gm_tau``, the sum
        over lags of :meth:`autocovariance` in closed form (its geometric tail beyond lag 1:
        sum_k>=2 e^(-a (k - 2)) cos(omega k) = Re[e^(-2 i omega) / (1 - e^(-a - i omega))]);
        traceable in both parameters."""
        a = 1.0 / (rate_hz * values["gm_tau"])
        c, x = _one_period(a) ** 2, -jnp.expm1(-a)
        excess = _lag_zero_excess(a)
        omega = 2.0 * jnp.pi * jnp.asarray(nu)
        tail = jnp.real(jnp.exp(-2j * omega) / (1.0 - jnp.exp(-a - 1j * omega)))
        spectrum = 2.0 * excess + 2.0 * (c * x - excess) * jnp.cos(omega) - 2.0 * c * x * x * tail
        return values["gm_sigma"] ** 2 * spectrum

    @classmethod
    def increment_autocovariance(cls, lags, values, rate_hz):
        """sigma^2 times :meth:`autocovariance` at the correlation time ``gm_tau``."""
        shape = cls(float(values["gm_tau"]))
        return float(values["gm_sigma"]) ** 2 * shape.autocovariance(lags, rate_hz)

    @classmethod
    def reference_scales(cls, allan) -> dict[str, float]:
        """The term's peak lies wherever its correlation time puts it, so the curve bounds
        sigma only by its largest value over the peak's height."""
        return {"gm_sigma": float(np.nanmax(allan.deviation)) / PEAK_DEVIATION}

    def rate_autocovariance(self, lags, rate_hz: float):
        """Autocovariance of period averages of an Ornstein-Uhlenbeck rate of unit variance:
        2 (a - 1 + e^-a) / a^2 at lag 0, ((1 - e^-a) / a)^2 e^(-a (k - 1)) at lag k >= 1, a =
        1 / (fs tau_c) (stable for a correlation time of many records' lengths)."""
        a = 1.0 / (rate_hz * self.time_constant_s)
        lags = np.abs(np.asarray(lags, dtype=float))
        apart = float(_one_period(a)) ** 2 * np.exp(-a * np.maximum(lags - 1.0, 0.0))
        return np.where(lags == 0, 2.0 * float(_integral_fraction(a)), apart)

    def autocovariance(self, lags, rate_hz: float):
        """Increment autocovariance of a unit-variance Gauss-Markov rate, 2 r(k) - r(k - 1) -
        r(k + 1) of :meth:`rate_autocovariance`, in closed form: 2 (r0 - c), c x - (r0 - c)
        and -c x^2 e^(-a (k - 2)) at lags 0, 1 and k >= 2, with c = r(1) and x = 1 - e^-a
        (the differences of near-equal numbers taken out, so that a correlation time far
        beyond a sample keeps its digits)."""
        a = 1.0 / (rate_hz * self.time_constant_s)
        lags = np.abs(np.asarray(lags, dtype=float))
        c, x = float(_one_period(a)) ** 2, -math.expm1(-a)
        excess = float(_lag_zero_excess(a))
        far = -c * x * x * np.exp(-a * np.maximum(lags - 2.0, 0.0))
        return np.where(lags == 0, 2.0 * excess, np.where(lags == 1, c * x - excess, far))

    def spectrum(self, nu, rate_hz: float):
        """Two-sided spectrum of the increments of a unit-variance term, per cycle per sample:
        4 sin^2(pi nu) times the period averages' spectrum r(0) + 2 Re sum_k r(k) e^(-2 pi i nu
        k), whose geometric tail (r(k) = c e^(-a (k - 1)) beyond lag 0) sums in closed form
        (:meth:`increment_spectrum`)."""
        values = {"gm_sigma": 1.0, "gm_tau": self.time_constant_s}
        return self.increment_spectrum(nu, values, rate_hz)

    def block_covariance(self, start, stop, rate_hz: float):
        """Covariance of block means of a unit-variance Gauss-Markov rate (continuous time):
        T^2 (1 - e^{-La/T}) (1 - e^{-Lb/T}) e^{-gap/T} / (La Lb) between blocks, and
        2 T^2 (L/T - 1 + e^{-L/T}) / L^2 for a block with itself."""
        a, b = start / rate_hz, stop / rate_hz
        t = self.time_constant_s
        fraction = (b - a) / t
        before = np.subtract.outer(a, b)  # a_i - b_j
        gap = np.maximum(np.maximum(before, before.T), 0.0)
        scaled, integral = (np.asarray(part) for part in _block_fractions(fraction))
        apart = np.outer(scaled, scaled) * np.exp(-gap / t)  # scaled: (1 - e^(-L/T)) / (L/T)
        same = 2.0 * integral
        return np.where(np.equal.outer(start, start), np.diag(same), apart)

    @classmethod
    def allan_variance(cls, tau, values, rate_hz):
        """(2 sigma^2 T / tau) [1 - T / (2 tau) (3 - 4 e^{-tau/T} + e^{-2 tau/T})] (IEEE Std
        952, annex C)."""
        ratio = jnp.asarray(tau, dtype=float) / values["gm_tau"]
        return (2 * values["gm_sigma"] ** 2 / ratio) * (
            1 - (3 - 4 * jnp.exp(-ratio) + jnp.exp(-2 * ratio)) / (2 * ratio)
        )

    @classmethod
    def level_change_variance(cls, gap_s, values, rate_hz):
        """2 sigma^2 (1 - e^(-t / tau_c)): a stationary level's change over t."""
        return 2 * values["gm_sigma"] ** 2 * (-jnp.expm1(-gap_s / values["gm_tau"]))

    @classmethod
    def allan_exponents(cls, tau, values, rate_hz):
        """A random walk below its correlation time, white noise above it."""
        variance = cls.allan_variance(tau, values, rate_hz)
        below = jnp.asarray(tau) < values["gm_tau"]
        return [(-2, jnp.where(below, variance, 0.0)), (0, jnp.where(below, 0.0, variance))]

    @classmethod
    def sample(cls, keys, n, rate_hz, values):
        """``n`` period averages of a stationary Ornstein-Uhlenbeck process, exactly: from
        x_k the pair (x_{k+1}, the integral over the period) is Gaussian with
        Var x = s^2 (1 - p^2), Var I = 2 s^2 T [d - 2 T (1 - p) + T (1 - p^2) / 2] and
        Cov = s^2 T (1 - p)^2, p = e^(-d / T), d the sample period (Gillespie 1996)."""
        sigma, time = values["gm_sigma"], values["gm_tau"]
        period = 1.0 / rate_hz
        decay = jnp.exp(-period / time)
        var_end = 1.0 - decay**2
        var_integral = 2 * time * (period - 2 * time * (1 - decay) + time * var_end / 2)
        covariance = time * (1 - decay) ** 2
        # The integral's part given the end's (Cholesky of the 2 x 2 covariance).
        along = covariance / jnp.sqrt(var_end)
        across = jnp.sqrt(jnp.maximum(var_integral - along**2, 0.0))
        start_key, steps_key = jax.random.split(keys[cls.streams[0]])
        draws = jax.random.normal(steps_key, (n, 2))

        def step(x, z):
            integral = x * time * (1 - decay) + along * z[0] + across * z[1]
            return decay * x + jnp.sqrt(var_end) * z[0], integral / period

        _, averages = jax.lax.scan(step, jax.random.normal(start_key), draws)
        return sigma * averages
