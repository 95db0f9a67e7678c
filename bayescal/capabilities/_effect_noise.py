"""The noise of a channel in the model that holds what discovery found on it.

A stationary noise model fitted to a record that holds an effect it lacks (a bias that follows
the temperature, a warm-up, a line) absorbs the effect into its own terms: a thermal drift
reads as a rate random walk, and the fit's checks may still pass. :func:`noise_with_effects`
gives the noise numbers that can be reported for such a channel: the posterior of the model
with both the noise fit's terms and the effects :func:`~bayescal.discover` named (discovery's
final model, with any noise term of the noise fit it lacks added, so that every noise number
the fit showed has its counterpart), sampled as discovery samples its final model
(:func:`~bayescal.inference._discovery_posterior.sample_final`) and checked as it checks it
(:func:`~bayescal.inference._checks.run_checks`).
"""

from dataclasses import dataclass

from ..inference._checks import FitCheck, run_checks
from ..inference._discovery_posterior import sample_final
from ..inference._discovery_search import UNMODELLED_CHECKS
from ..inference._mcmc import summarize
from ..inference._sampler import Sampler, sampler_of
from ..models._composite import BASELINE_TERMS
from ..models._terms import FILTER_SHAPE_OF_TERM
from ..models.effects._catalogue import CATALOGUE
from ._discovery import Discovery
from ._noise import NoiseFit

ADDED_TERMS = tuple(
    name for name in BASELINE_TERMS if name not in ("white", "gauss_markov", "output_filter")
)
"""The noise fit's terms that join discovery's final model when it lacks them: the terms of
fixed shape (a Gauss-Markov term's time constant is searched, and the output filter is
decided by discovery itself, before its search)."""


@dataclass(frozen=True)
class EffectNoise:
    """The noise of a channel in the model that holds the effects discovery found
    (:func:`noise_with_effects`): every parameter's posterior summary, the sampler's checks
    and the model's checks against the record."""

    channel: str
    unit: str
    effects: tuple[str, ...]
    """The effects discovery named that the noise fit lacks (what it absorbed)."""
    terms: tuple[str, ...]
    """The model's terms, the bias first: the noise terms, then the effects."""
    added: tuple[str, ...]
    """The noise fit's terms added to discovery's final model (empty: its posterior is
    discovery's own)."""
    parameters: dict
    """parameter -> ``{mean, sd, q05, q95, unit}`` (90 % interval): the noise scales (N, B,
    K ...) and the effects' coefficients (c1 ...)."""
    diagnostics: object
    """The sampler's checks (R-hat, ESS, autocorrelation time, acceptance)."""
    checks: tuple[FitCheck, ...]
    """The model's checks against the record (discovery's: Allan deviation, spectrum, line,
    residual over time and against each covariate ...), each passed at p >= 0.01."""

    @property
    def failures(self) -> tuple[str, ...]:
        """The failed sampler checks, then the checks of the model against the record that
        failed."""
        return (
            *self.diagnostics.failures,
            *(f"model misfit: {check.misfit}" for check in self.checks if not check.passed),
        )

    @property
    def passed(self) -> bool:
        """Whether the posterior passed its sampler checks and the model its checks."""
        return not self.failures


def absorbed_effects(noise: NoiseFit, discovery: Discovery) -> tuple[str, ...]:
    """The effects discovery named that the noise fit's model lacks, so absorbed into its
    terms: neither a term the fit holds, nor an output filter where the fit holds one of its
    shapes, nor the rounding grid where the fit models it (its LSB)."""
    holds_filter = any(term in FILTER_SHAPE_OF_TERM for term in noise.terms)
    absorbed = []
    for effect in discovery.effects:
        if effect.name in noise.terms:
            continue
        if effect.name in FILTER_SHAPE_OF_TERM and holds_filter:
            continue
        grid_only = "white_angle_noise" not in effect.evidence
        if effect.name == "quantization" and noise.lsb > 0 and grid_only:
            continue
        absorbed.append(effect.name)
    return tuple(absorbed)


def _fit_check(check: dict) -> FitCheck:
    passed = bool(check["passed"])
    return FitCheck(
        name=check["name"],
        statistic=check["statistic"],
        p_value=check["p_value"],
        location=check["location"],
        passed=passed,
        misfit="" if passed else f"{check['name']} fails (p = {check['p_value']:.2g})",
        curve=check.get("curve", {}),
    )


def noise_with_effects(
    noise: NoiseFit, discovery: Discovery, *, seed: int = 0, sampler: Sampler = Sampler()
) -> EffectNoise | None:
    """The posterior of the channel's noise in the model that holds the effects discovery
    found and the noise fit's terms; None when the noise fit lacks none of those effects (its
    own numbers stand).

    Parameters
    ----------
    noise : NoiseFit
        The channel's noise fit (:func:`~bayescal.fit_noise`).
    discovery : Discovery
        Discovery on the same channel (:func:`~bayescal.discover`).
    seed : int
        Seed of the posterior's sampler (the same inputs and seed give the same posterior).
    sampler : Sampler
        How the posterior is sampled.

    Returns
    -------
    EffectNoise or None
        Every parameter's posterior summary in its unit, the sampler's checks and the
        model's checks; None when nothing was absorbed.
    """
    effects = absorbed_effects(noise, discovery)
    if not effects:
        return None
    result = discovery.result
    spec = result.final.spec
    added = tuple(term for term in noise.terms if term in ADDED_TERMS and not spec.has(term))
    if added or discovery.posterior is None:
        for term in added:
            spec = spec.with_effect(CATALOGUE[term]())
        fit = result.context.fit(spec)
        checks = run_checks(fit, result.data)
        posterior = sample_final(fit, result.data, seed=seed, sampler=sampler_of(sampler))
    else:
        fit, checks, posterior = result.final, result.final_checks, discovery.posterior
    return EffectNoise(
        channel=discovery.channel,
        unit=discovery.unit,
        effects=effects,
        terms=tuple(fit.spec.terms()),
        added=added,
        parameters={
            name: summarize(draws, posterior.units[name]) for name, draws in posterior.draws.items()
        },
        diagnostics=posterior.diagnostics,
        checks=tuple(
            _fit_check(check) for check in checks if check["name"] not in UNMODELLED_CHECKS
        ),
    )
