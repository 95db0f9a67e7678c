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
import jax.numpy as jnp
import numpy as np

from ... import _x64  # noqa: F401  (float64 before any JAX array)
from ...recording._units import convert
from ._parameter import Context, Parameter

GRID_POINTS = 6
"""Points of the log grid a time constant is first searched on."""
PARABOLIC_STEPS = 3
"""Refinements of a searched time constant by a parabola through the best score and its two
neighbours (in log time constant), after the grid and its midpoints."""
SHORTEST_DECAY_S = 5.0
"""The shortest time constant a search looks at by default, s (a warm-up decays over
minutes; one over seconds is lost in the power-on). A term whose time constant can be as
short as a few tenths of a second (a Gauss-Markov bias) searches from a few samples
instead."""
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

    def search_time(self, make_spec, key: str, shortest_s: float = SHORTEST_DECAY_S):
        """The best fit over a searched time constant from ``shortest_s`` (s; the grid from 20
        samples, extended to a sample where its best is there) up: (fit, search record); None
        when the record is too short to search one (its third no longer than the grid's
        start)."""

    def line_frequency(self, fit) -> float:
        """The frequency of the strongest spectral line the fit leaves in its residual."""

    def level_event(self, fit, kind: str):
        """The time of the strongest departure of ``kind`` (``"step"``) the level scan of
        the fit locates, and the search's record; None where it locates none. For
        ``"switches"``, the times of the level changes where it locates switching levels."""

    def strongest_step(self, fit):
        """The time of the step the level scan's shapes see standing out most in the fit's
        residual, however little, and the search's record; None where there is no step
        shape."""

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

    def apart(self, check: dict, duration_s: float) -> bool:
        """Whether ``check`` — this effect's own check, still failing with the effect in the
        model — locates a mismatch apart from this effect (so the effect explained its own
        and is kept, the rest reported unexplained). Default: no, the effect did not explain
        what located it."""
        return False


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
    """A term of the stationary noise model (abstract): one class in one file, registered once
    in :data:`bayescal.models._terms.NOISE_TERMS`, from which the model, the term search, the
    priors, the units, the report and the command line read it.

    A term declares its name and aliases, its parameters (:class:`Parameter`: unit, whether
    datasheets quote it, coordinate and prior), its classical reading and the sensor-card
    entries that give it, and computes, from its parameters by name (``values``; JAX arrays
    broadcast):

    - its *components* of the spectrum of the sample increments (:meth:`components`): each a
      fixed shape — the increments' autocovariance (numpy, integer lags), their two-sided
      spectrum (per cycle per sample), the covariance of block means (the nonstationary
      terms started at the first sample) — times a weight (:meth:`weights`); the likelihoods
      of bayescal take their expected periodograms once per record and the weights at every
      draw;
    - its Allan variance (:meth:`allan_variance`) and the power-law exponents that dominate it
      (:meth:`allan_exponents`, for the EDF of a check);
    - its samples (:meth:`sample`), from the PRNG streams it owns (:attr:`streams`).

    The output filter's shapes shape the white noise instead (:attr:`filter_shape`,
    :meth:`gain`), and the ramp adds to the mean increment (:attr:`mean_rate`).

    A term may instead be a deterministic part *found in the record* before the stochastic
    terms are fitted (:attr:`found_in_record`, :meth:`find`: spectral lines at frequencies a
    test locates). What it finds is taken out of the record (``removed``), bands it cannot
    take out are left out of the likelihood (``excluded_bands_hz``), and the stochastic
    terms' posterior, its checks and N are of what is left; its parameters, one set per item
    found, are estimated there and never sampled (they hold no prior and no place in a
    posterior's coordinates). The model (:class:`~bayescal.NoiseModel`) simulates it and
    takes its Allan variance from them all the same.
    """

    aliases: ClassVar[tuple[str, ...]] = ()
    """Other names a user may give it (``--terms``, ``terms=``), lower case."""
    parameters: ClassVar[tuple[Parameter, ...]] = ()
    """Its parameters, in order."""
    candidate: ClassVar[bool] = True
    """Whether ``terms="auto"`` tries it (white noise is always in the model)."""
    filter_shape: ClassVar[str | None] = None
    """The output filter's shape it is (one filter shape per model), or None."""
    mean_rate: ClassVar[str | None] = None
    """The parameter that is a steady drift of the mean (the ramp), or None."""
    streams: ClassVar[tuple[int, ...]] = ()
    """Indices of the PRNG streams its samples draw on (``jax.random.split`` of a model's key;
    fixed forever: the same seed gives the same record in every release)."""
    reading: ClassVar[object] = None
    """Its classical reading off the Allan deviation (:mod:`bayescal.classical._noise`:
    IEEE Std 952 Annex C), or None."""
    classical_caveat: ClassVar[str] = ""
    """Why its classical reading and its posterior can disagree (for the report's notes)."""
    card_entries: ClassVar[tuple[str, ...]] = ()
    """The sensor-card entries that give its first parameter, the first present used
    (``noise_density``, ``angle_random_walk`` ...; models/README.md)."""
    long_memory: ClassVar[bool] = False
    """Its increments are correlated at every lag (flicker), not only at the first few."""
    filtered: ClassVar[bool] = False
    """Whether the output filter's low-pass shapes its components (the white noise's)."""
    found_in_record: ClassVar[bool] = False
    """Whether the term is a deterministic part found in the record before the stochastic
    terms are fitted (:meth:`find`; the class docstring)."""

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.__dict__.get("parameters"):
            cls.parameter = cls.parameters[0].name

    @classmethod
    def find(cls, values, rate_hz: float, transform=None):
        """What a term :attr:`found_in_record` finds in a record (NaN marks a missing
        sample), before any fit: an object with ``found`` (whether there is anything),
        ``removed(values)`` (the record without it), ``excluded_bands_hz`` (bands, Hz, the
        stochastic fit leaves out), ``left_in`` (what stays in the record less it, as a noise
        model's parameters, for the checks of the fit), ``verdict`` (what was found, in
        words, for the term search's table) and ``log_bayes_factor`` (its evidence against
        the record without it). None for the other terms. ``transform``: the tapered
        transform of the record's longest run without a gap, where already taken
        (:func:`~bayescal.classical._periodogram.longest_run_transform`), for a term that
        reads it."""
        return None

    @classmethod
    def components(cls, context: Context) -> tuple:
        """Its components of the increments' spectrum for a record (:class:`Context`): objects
        with ``autocovariance``, ``spectrum``, ``block_covariance`` and ``long_memory``
        (the class itself for a fixed shape). None by default."""
        return ()

    @classmethod
    def weights(cls, values: dict, components: tuple):
        """The weight of each of ``components`` (its own, :meth:`components`) at ``values``:
        an array (..., len(components)), variance per sample of each shape."""
        raise NotImplementedError

    @classmethod
    def increment_spectrum(cls, nu, values: dict, rate_hz: float):
        """Its part of the two-sided spectrum of the increments at ``nu`` cycles per sample
        (parameters broadcast against ``nu``): its components' spectra times their weights."""
        shapes = cls.components(Context(rate_hz))
        if not shapes:
            return 0.0 * jnp.asarray(nu)
        weights = cls.weights(values, shapes)
        return sum(weights[..., k] * shape.spectrum(nu, rate_hz) for k, shape in enumerate(shapes))

    @classmethod
    def increment_autocovariance(cls, lags, values: dict, rate_hz: float) -> np.ndarray:
        """Its part of the increments' autocovariance at integer ``lags`` (numpy; parameters
        numbers)."""
        shapes = cls.components(Context(rate_hz))
        if not shapes:
            return np.zeros(np.shape(lags))
        weights = np.asarray(cls.weights(values, shapes))
        return sum(
            weights[k] * shape.autocovariance(lags, rate_hz) for k, shape in enumerate(shapes)
        )

    @classmethod
    def allan_variance(cls, tau, values: dict, rate_hz: float):
        """Its Allan variance at averaging times ``tau`` (s), the channel's unit squared;
        zero for a term without one of its own (a filter shape: :meth:`shaped_allan_variance`
        of the white noise instead)."""
        return 0.0 * jnp.asarray(tau, dtype=float)

    @classmethod
    def level_change_variance(cls, gap_s: float, values: dict, rate_hz: float):
        """Variance of the change of its level over ``gap_s`` seconds (what separates two
        static sections of one file): zero for a stationary term."""
        return 0.0

    @classmethod
    def allan_exponents(cls, tau, values: dict, rate_hz: float) -> list[tuple[int, object]]:
        """(alpha, Allan variance) pairs: the power-law exponent alpha of S_y(f) its Allan
        variance has at each tau (for the equivalent degrees of freedom of a check)."""
        return []

    @classmethod
    def sample(cls, keys, n: int, rate_hz: float, values: dict):
        """Its part of ``n`` samples (added to the others'), drawn from ``keys[i]`` for each
        stream i it owns; zero by default."""
        return jnp.zeros(n)

    @classmethod
    def gain(cls, nu, values: dict, rate_hz: float):
        """|H|^2 at ``nu`` cycles per sample of a filter shape (:attr:`filter_shape`)."""
        raise NotImplementedError

    @classmethod
    def reference_scales(cls, allan) -> dict[str, float]:
        """The level of each parameter without a fixed prior that the classical Allan curve
        ``allan`` allows (its upper bound): where its weakly informative prior is centred."""
        if cls.reading is None:
            return {}
        return {cls.parameters[0].name: cls.reading.bound(allan)}

    @classmethod
    def card_values(cls, section: dict, channel_unit: str) -> dict[str, tuple[float, str]]:
        """Its first parameter from a sensor card's section (the first of
        :attr:`card_entries` present), in its unit for a channel in ``channel_unit``, with
        where in the datasheet it comes from.

        Raises
        ------
        ValueError
            A card unit of another dimension than the parameter's (the message names it).
        """
        parameter = cls.parameters[0] if cls.parameters else None
        for entry in cls.card_entries:
            if entry in section:
                item = section[entry]
                value = cls.card_value(item, parameter.unit_for(channel_unit))
                return {parameter.name: (value, item["source"])}
        return {}

    @classmethod
    def card_value(cls, item: dict, unit: str) -> float:
        """A card entry's value (``{value, unit, source}``) in ``unit``."""
        try:
            return convert(item["value"], item["unit"], unit)
        except ValueError as error:
            raise ValueError(
                f"unit '{item['unit']}' does not give {cls.parameters[0].meaning} "
                f"{cls.parameters[0].name} ({unit} or a unit of that dimension): {error}"
            ) from None


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
