"""The population of a fleet: several units of one part, each recorded in one or more runs
(power-ups), as one hierarchical model whose simulator and log density share its parameters.

For unit u and its runs r (../shared/DESIGN.md, "Fleets"):

    log p_u ~ Normal(mu_p, sigma_p)     each noise scale p of N, B, K in the model: a property
                                        of the unit, the same in all its runs
    beta_u  ~ Normal(mu_b, tau_unit)    the unit's mean turn-on bias
    b_ur    ~ Normal(beta_u, tau_run)   the turn-on bias of run r (turn-on repeatability)

The population's parameters are the median exp(mu_p) of each noise scale with the sd sigma_p
of its natural log across units, the mean bias mu_b, the bias's unit-to-unit sd tau_unit and
its run-to-run sd tau_run. The noise scales are independent across parameters in the
population (a unit with a high N is not assumed to have a high B).

Likelihood, from each recording's stored posterior draws (no second pass over the data). The
per-unit parameters are integrated out by reweighting draws by population prior over fitting
prior (Hogg, Myers & Bovy 2010, "Inferring the eccentricity distribution", ApJ 725, 2166,
eq. 9): for a unit with one run, whose draws x_k were drawn under the fitting prior pi_0,

    p(d_u | alpha) ~ (1/K) sum_k p(x_k | alpha) / pi_0(x_k)  (times the bias factor below).

A unit with several runs shares its noise scales across them, so its runs' likelihoods
multiply at one point: its points are its runs' draws pooled, each carrying the weight
c_j = prod_r p_r(x_j) / pi_r(x_j) / q(x_j), prod_r L_r(x_j) over the pooled draws' density q,
precomputed from the stored draws (:mod:`bayescal.inference._population`); one run gives
c_j = 1 / pi_0(x_j) exactly. Each point also carries, for each run, the bias's Gaussian
posterior given the noise (mean m_r, variance v_r; flat fitting prior, so its likelihood), so
that the biases integrate out in closed form:

    integral prod_r N(m_r; b_r, v_r) N(b_r; beta, tau_run^2) N(beta; mu_b, tau_unit^2)
        = prod_r N(m_r; m_hat, s_r) * sqrt(2 pi / W) * N(m_hat; mu_b, 1/W + tau_unit^2)
    with s_r^2 = v_r + tau_run^2, W = sum_r 1/s_r^2, m_hat = sum_r m_r / s_r^2 / W.

Spreads a fleet cannot identify are left out of the model rather than left to their prior: with
one unit there is no spread across units (the unit's noise scales then have a flat prior in
the log), and with one run per unit the bias's run-to-run sd cannot be told from its
unit-to-unit sd (the latter then holds both).

Prior of the population (sampled in mu, log sd): mu_p and mu_b flat; sigma_p half-Cauchy with
scale LOG_SD_PRIOR_SCALE (a factor e between units is already a wide spread for one part);
tau_unit and tau_run half-Cauchy with a scale of ten times the fleet's own spread of biases:
proper, and flat over every sd the fleet could show (Gelman 2006: a uniform prior on the sd
once there are more than a handful of groups). A scale of the spread itself pulls tau_unit
down, the direction that understates a part's bias repeatability. The exact posterior on a grid
over simulated fleets (``python benchmarks/fleet_bias_exact.py --grid-only --fleets 1000``,
seeds 2, 7 and 9 pooled, 8-40 units): with the spread as the scale, its 90 % interval of
tau_unit held the truth in 90.4 % of 3,000 fleets, but missed it low (the truth above the
interval) 182 times and high 105; with ten times the spread, 91.5 %, missed low 114 times and
high 140. For 3-7 units (seed 8, 1,000 fleets): 89.0 % (79 low, 31 high) against 93.6 %
(10 low, 54 high)."""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.special import logsumexp

from .. import _x64  # noqa: F401  (float64 before any JAX array)

LOG_SD_PRIOR_SCALE = 1.0
"""Scale of the half-Cauchy prior of the sd of a noise scale's natural log across units."""
BIAS_SD_PRIOR_FACTOR = 10.0
"""Scale of the half-Cauchy priors of the bias's unit-to-unit and run-to-run sds, in units of
the fleet's own spread of turn-on biases (the module docstring says why ten)."""
_LOG_2PI = math.log(2 * math.pi)


class FleetPopulation(eqx.Module):
    """The population of a fleet, and its simulator: the true parameters of units and runs.

    Parameters
    ----------
    median : dict
        Noise parameter (``N``, ``B``, ``K``) -> population median, in the parameter's unit.
    log_sd : dict
        Noise parameter -> sd of its natural logarithm across units (0: all units alike).
    bias_mean : float
        Mean turn-on bias of the population, in the channel's unit.
    bias_unit_sd : float
        Unit-to-unit sd of the unit's mean turn-on bias.
    bias_run_sd : float
        Run-to-run sd of the turn-on bias of one unit (turn-on repeatability).

    Examples
    --------
    >>> from bayescal.models._population import FleetPopulation
    >>> population = FleetPopulation({"N": 0.004}, {"N": 0.2}, 0.3, 0.05, 0.02)
    >>> units = population.simulate([2, 1, 3], seed=0)
    >>> [len(unit["bias"]) for unit in units]
    [2, 1, 3]
    """

    median: dict
    log_sd: dict
    bias_mean: float
    bias_unit_sd: float
    bias_run_sd: float

    def __check_init__(self):
        if set(self.median) != set(self.log_sd):
            raise ValueError("median and log_sd must name the same parameters")
        if not all(value > 0 for value in self.median.values()):
            raise ValueError("every population median must be positive")
        if not all(value >= 0 for value in (*self.log_sd.values(), self.bias_unit_sd)):
            raise ValueError("every sd must be non-negative")
        if not self.bias_run_sd >= 0:
            raise ValueError("bias_run_sd must be non-negative")

    def simulate(self, runs_per_unit, seed: int = 0) -> list[dict]:
        """The true parameters of a fleet: for each unit, its noise scales (shared by its
        runs) and the turn-on bias of each of its runs (``runs_per_unit[i]`` of them).

        Parameters
        ----------
        runs_per_unit : sequence of int
            How many runs (power-ups) each unit has.
        seed : int
            The same seed gives the same fleet.

        Returns
        -------
        list of dict
            One per unit: parameter -> value, ``unit_bias`` -> its mean turn-on bias, and
            ``bias`` -> array of its runs' turn-on biases.
        """
        rng = np.random.default_rng(seed)
        units = []
        for runs in runs_per_unit:
            unit = {
                name: float(median * math.exp(self.log_sd[name] * rng.standard_normal()))
                for name, median in sorted(self.median.items())
            }
            unit["unit_bias"] = self.bias_mean + self.bias_unit_sd * rng.standard_normal()
            unit["bias"] = unit["unit_bias"] + self.bias_run_sd * rng.standard_normal(int(runs))
            units.append(unit)
        return units


class PopulationModel(eqx.Module):
    """The log density of a fleet's population parameters, from the weighted points of each
    unit (padded to common sizes: U units, J points, R runs, d noise parameters).

    Sampled coordinates, in this order, those present: mu of each noise parameter, log sigma
    of each (with more than one unit), mu_b, log tau_unit (more than one unit), log tau_run
    (a unit with more than one run).
    """

    log_weight: jax.Array
    """(U, J) log c_j of each point; -inf pads."""
    points: jax.Array
    """(d, U, J) natural logs of the noise parameters at each point."""
    bias_mean: jax.Array
    """(R, U, J) mean of each run's bias given the noise at each point."""
    bias_variance: jax.Array
    """(R, U, J) its variance (1 where a run pads)."""
    unit_mask: jax.Array
    """(U,) 1.0 for a unit, 0.0 for padding (sizes are rounded up, so that fleets of similar
    sizes share one compiled density)."""
    run_mask: jax.Array
    """(R, U) 1.0 for a run, 0.0 for padding. (Parameters and runs lead the arrays: the
    sums over them are then whole-array operations, ten times faster than over a last axis
    of two or three.)"""
    bias_spread: jax.Array
    """The fleet's own spread of turn-on biases, the channel's unit: the half-Cauchy priors of
    tau_unit and tau_run have BIAS_SD_PRIOR_FACTOR times it as their scale."""
    parameters: tuple[str, ...] = eqx.field(static=True)
    unit_spread: bool = eqx.field(static=True)
    """More than one unit: the spreads across units are in the model."""
    run_spread: bool = eqx.field(static=True)
    """A unit with several runs: the bias's run-to-run sd is in the model."""

    @property
    def names(self) -> tuple[str, ...]:
        """The sampled coordinates, by name."""
        names = []
        if self.unit_spread:
            names += [f"mu_{p}" for p in self.parameters]
            names += [f"log_sigma_{p}" for p in self.parameters]
        names.append("mu_bias")
        if self.unit_spread:
            names.append("log_tau_unit")
        if self.run_spread:
            names.append("log_tau_run")
        return tuple(names)

    def unpack(self, theta) -> dict:
        """Coordinates -> mu (..., d), sigma (..., d) (absent with one unit), mu_bias,
        tau_unit and tau_run (zero where left out)."""
        d = len(self.parameters) if self.unit_spread else 0
        values = {}
        if self.unit_spread:
            values["mu"] = theta[..., :d]
            values["sigma"] = jnp.exp(theta[..., d : 2 * d])
        values["mu_bias"] = theta[..., 2 * d]
        zero = jnp.zeros_like(values["mu_bias"])
        values["tau_unit"] = jnp.exp(theta[..., 2 * d + 1]) if self.unit_spread else zero
        values["tau_run"] = jnp.exp(theta[..., -1]) if self.run_spread else zero
        return values

    def log_prior(self, theta):
        """Flat in the means; half-Cauchy on each sd, with the Jacobian of its log."""
        values = self.unpack(theta)

        def half_cauchy_of_log(sd, scale):
            return jnp.log(2 / jnp.pi) + jnp.log(scale) - jnp.log(scale**2 + sd**2) + jnp.log(sd)

        bias_scale = BIAS_SD_PRIOR_FACTOR * self.bias_spread
        total = 0.0
        if self.unit_spread:
            total = total + jnp.sum(half_cauchy_of_log(values["sigma"], LOG_SD_PRIOR_SCALE))
            total = total + half_cauchy_of_log(values["tau_unit"], bias_scale)
        if self.run_spread:
            total = total + half_cauchy_of_log(values["tau_run"], bias_scale)
        return total

    def point_log_weights(self, theta):
        """(U, J) log of each point's term in its unit's likelihood: c_j times the population
        density of its noise scales times its biases' integral over beta_u and the b_ur."""
        values = self.unpack(theta)
        total = self.log_weight
        if self.unit_spread:
            for index, points in enumerate(self.points):
                mu, sigma = values["mu"][..., index], values["sigma"][..., index]
                z = (points - mu) / sigma
                total = total - 0.5 * z**2 - jnp.log(sigma) - 0.5 * _LOG_2PI
        return total + self._bias_log_integral(values)

    def _bias_log_integral(self, values):
        """(U, J) log of the integral over beta_u and the runs' biases (module docstring)."""
        precisions = [
            mask[:, None] / (variance + values["tau_run"] ** 2)
            for variance, mask in zip(self.bias_variance, self.run_mask, strict=True)
        ]
        total_precision = sum(precisions)
        centre = sum(p * mean for p, mean in zip(precisions, self.bias_mean, strict=True))
        centre = centre / total_precision
        logs = sum(
            mask[:, None] * jnp.log(p + (1 - mask[:, None]))  # padded runs add nothing
            for p, mask in zip(precisions, self.run_mask, strict=True)
        )
        scatter = sum(
            p * (mean - centre) ** 2 for p, mean in zip(precisions, self.bias_mean, strict=True)
        )
        runs = jnp.sum(self.run_mask, 0)[:, None]
        spread = 1.0 / total_precision + values["tau_unit"] ** 2
        return 0.5 * (logs - scatter - (runs - 1) * _LOG_2PI - jnp.log(total_precision)) - 0.5 * (
            _LOG_2PI + jnp.log(spread) + (centre - values["mu_bias"]) ** 2 / spread
        )

    def unit_log_likelihood(self, theta):
        """(U,) log p(d_u | population), each up to a constant of its own (0 for padding)."""
        return self.unit_mask * logsumexp(self.point_log_weights(theta), axis=-1)

    def log_density(self, theta):
        value = self.log_prior(theta) + jnp.sum(self.unit_log_likelihood(theta))
        return jnp.where(jnp.isfinite(value), value, -jnp.inf)
