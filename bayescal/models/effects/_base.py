"""What every effect of the catalogue is, and what discovery asks of it.

An effect has a catalogue name, an explanation for a user, and the check of a fitted model
that points to it when the model lacks it. It enters the composite model discovery grows
(:mod:`bayescal.models._composite`) in one of three ways:

- a noise term (:class:`NoiseTerm`) takes one *slot* of the model's noise parameters: a
  component of the spectrum of the sample increments, a fixed shape times its parameter
  squared (or, for the ramp, the mean increment);
- a deterministic term (:class:`RegressionTerm`) adds columns to the mean, whose coefficients
  the likelihood takes exactly;
- a sample effect (clipping, glitches) changes which samples the model is fitted to.

Each effect also proposes itself to discovery (:meth:`Effect.propose`): given the current
model, the fits with it added, through the :class:`Search` discovery passes in (so that an
effect file needs nothing of the layers above the models); and it summarises its own
parameters from the final posterior (:meth:`Effect.describe`). Adding an effect is one file
and one line in :mod:`._catalogue`.
"""

import math
from typing import ClassVar, Protocol

import equinox as eqx
import numpy as np

GRID_POINTS = 6
"""Points of the log grid a time constant is first searched on."""
PARABOLIC_STEPS = 3
"""Refinements of a searched time constant by a parabola through the best score and its two
neighbours (in log time constant), after the grid and its midpoints."""
SEARCHED_VALUES = 2 * GRID_POINTS - 1 + PARABOLIC_STEPS
"""Values a time-constant search chooses among: with a uniform prior over them, the marginal
likelihood is at least the best one's divided by their number."""


class Search(Protocol):
    """What discovery offers an effect proposing itself: its data, a fit of a model, the two
    searches for nonlinear parameters, and the summaries of a posterior."""

    data: object
    """The channel and the series it may depend on (temperature, accelerometers)."""

    def fit(self, spec):
        """The MAP fit of model ``spec``."""

    def search_time(self, make_spec, key: str):
        """The best fit over a searched time constant: (fit, search record); None when the
        record is too short to search one (its third no longer than the shortest)."""

    def line_frequency(self, fit) -> float:
        """The frequency of the strongest spectral line the fit leaves in its residual."""

    def summarize(self, draws, unit: str) -> dict:
        """Mean, sd, 5 % and 95 % quantiles of posterior draws, with the unit."""

    def profile_interval(self, search: dict) -> dict:
        """The 90 % profile-likelihood interval of a searched time constant."""

    def widened(self, summary: dict, search: dict, name: str, time_constant: dict, log_scale: bool):
        """A parameter's interval widened by the uncertainty of the time constant it is tied
        to."""

    def frequency_interval(self, fit, index: int, amplitude: float) -> dict:
        """The interval of a sinusoid's located frequency."""


class Effect(eqx.Module):
    """An effect of ../shared/DESIGN.md's catalogue (abstract).

    Concrete effects set the class variables; one with a nonlinear parameter fixed by a
    search (a time constant, a frequency) is an instance holding it.
    """

    name: eqx.AbstractClassVar[str]
    """The catalogue name, as discovery reports it."""
    explanation: eqx.AbstractClassVar[str]
    """What the physics is and how it shows, for a user."""
    located_by: eqx.AbstractClassVar[str]
    """The check of a fitted model that points to this effect when the model lacks it."""
    band: eqx.AbstractClassVar[str]
    """Where it shows: "low" (slow drifts, up to the record's length), "line" (a spectral
    line), "high" (the shape of the spectrum toward Nyquist) or "samples" (the samples'
    distribution). Effects of one band can look alike on a short record; of two, never."""
    rank: ClassVar[int] = 0
    """Where the effect is listed among a model's terms: noise terms first, in the order
    they were added, then deterministic terms and sample effects by rank."""

    def search_penalty(self, n_frequencies: int) -> float:
        """log of the number of values a search for this effect's nonlinear parameter chose
        among (zero when it has none)."""
        return 0.0

    @property
    def searched(self) -> int:
        """Nonlinear parameters of this effect fixed by a search."""
        return 0

    @classmethod
    def propose(cls, search: Search, current) -> tuple | None:
        """The fit of the current model with this effect added, and what its search recorded
        (``(fit, record)``), or None when it does not apply (already there, no covariate)."""
        return None

    def describe(self, finding, posterior, search: Search) -> dict:
        """This effect's parameters from the final posterior: name -> summary with its unit
        and interval."""
        return {}

    @property
    def decided_before_search(self) -> bool:
        """Whether the effect's parameters were fixed before the search (a grid's step, an
        output filter's shape), so that they are reported without a final posterior."""
        return False

    def location(self, finding, checks: dict) -> dict:
        """Where the effect was located: the baseline check that points to it."""
        location = dict(checks[self.located_by]["location"]) if self.located_by in checks else {}
        location["check"] = self.located_by
        return location


class SlotTerm(Effect):
    """A term with one parameter among the noise model's (abstract): a stochastic term, or
    the rate ramp, which the mean increment carries."""

    parameter: eqx.AbstractClassVar[str]
    """Its parameter's symbol (IEEE Std 952's where the standard has one)."""

    @classmethod
    def propose(cls, search: Search, current) -> tuple | None:
        if current.spec.has(cls.name):
            return None
        return search.fit(current.spec.with_effect(cls())), {}

    def describe(self, finding, posterior, search: Search) -> dict:
        return {
            self.parameter: search.summarize(
                posterior.draws[self.parameter], posterior.units[self.parameter]
            )
        }


class NoiseTerm(SlotTerm):
    """A stochastic term of the stationary noise model (abstract).

    It adds one component to the spectrum of the sample increments: a fixed shape times a
    weight, the square of its parameter. Each concrete term gives, per unit weight, the
    increments' autocovariance (numpy, integer lags), their two-sided spectrum (per cycle per
    sample), the covariance of block means (the nonstationary terms started at the first
    sample), and its Allan variance.
    """

    long_memory: eqx.AbstractClassVar[bool]
    """Its increments are correlated at every lag (flicker), not only at the first few."""


class RegressionTerm(Effect):
    """A deterministic term of the mean (abstract): columns whose coefficients the likelihood
    takes exactly (a Gaussian integral), each with the scale that turns its coefficient back
    into the channel's units."""

    max_columns: ClassVar[int]
    """The most columns this kind of term adds to one model."""
    slow: ClassVar[bool] = True
    """Its coefficients come from the block means (a slow term), else from the increments'
    periodogram (a line)."""

    def column_names(self, index: int) -> list[str]:
        """Names of its coefficients; ``index`` counts the terms of its kind before it in the
        model."""
        raise NotImplementedError

    def columns(self, data, time_s: np.ndarray) -> tuple[list, list, list]:
        """(columns, scales, units) of this term for ``data``: each column, the scale that
        turns its coefficient back into the channel's units, and that unit."""
        raise NotImplementedError

    def derive(self, draws: dict, units: dict, index: int) -> None:
        """Turn its coefficients' posterior draws (in ``draws`` and ``units``, by name) into
        the parameters it reports (in place); they are reported as they are by default."""


def standardized(column: np.ndarray) -> np.ndarray:
    """A column centred and scaled to unit sd (left unscaled where it does not vary)."""
    column = column - np.nanmean(column)
    scale = np.nanstd(column)
    return column / scale if scale > 0 else column


def varies(series: np.ndarray) -> bool:
    """Whether a covariate takes at least three values (enough to fit a slope on)."""
    finite = series[np.isfinite(series)]
    return finite.size > 0 and np.unique(finite).size >= 3 and np.ptp(finite) > 0


def moving_average(lags: np.ndarray, weights: tuple[float, ...]) -> np.ndarray:
    """An autocovariance that is ``weights[k]`` at lag k and zero beyond."""
    return sum(weight * (lags == lag) for lag, weight in enumerate(weights))


TIME_CONSTANT_PENALTY = math.log(SEARCHED_VALUES)
