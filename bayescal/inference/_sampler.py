"""The settings of the sampler every posterior is drawn with (:class:`Sampler`), apart from
the sampler itself (:mod:`._mcmc`) so that a caller, the command line included, builds them
without loading it."""

from dataclasses import dataclass

import numpy as np

from .._errors import InputError


@dataclass(frozen=True)
class Sampler:
    """How a posterior is sampled: the settings of emcee's ensemble, passed as ``sampler=`` to
    every capability that samples one (:func:`~bayescal.fit_noise`,
    :func:`~bayescal.calibrate_two_position`, :func:`~bayescal.calibrate_multi_position`,
    :func:`~bayescal.fit_thermal` and :meth:`~bayescal.ThermalCalibration.update`,
    :func:`~bayescal.discover`, :func:`~bayescal.fit_fleet`).

    Walkers start from the Laplace approximation at the MAP and move by differential evolution
    until the chain is longer than 50 autocorrelation times at two successive checks and its
    R-hat and bulk ESS pass (a borderline run runs on); the posterior then passes its checks
    (R-hat, bulk ESS, acceptance) or the result says which it failed
    (:mod:`bayescal.inference._mcmc`).

    The seed is not a setting of the sampler: it stays a keyword of each call (``seed=``),
    since it also seeds what is drawn outside emcee (discovery's imputation of clipped
    samples, the two-position calibration's levels, each recording of a fleet) and a result
    records it, so that one ``Sampler`` serves every channel and every seed.

    Parameters
    ----------
    n_walkers : int
        Walkers of the ensemble (at least 2); raised where a model needs more (twice its
        dimension plus two, rounded up to a multiple of the 4 groups R-hat compares).
    max_steps : int
        The most steps before sampling stops; a chain that has not met the autocorrelation
        criterion, or whose R-hat or ESS is still short of its bar, by then fails its checks.
    progress : bool
        A progress bar on stderr.

    Raises
    ------
    InputError
        ``n_walkers`` below 2 or ``max_steps`` below 1, or either not a whole number.

    Examples
    --------
    >>> import bayescal as bc
    >>> bc.Sampler(n_walkers=64)
    Sampler(n_walkers=64, max_steps=40000, progress=False)
    """

    n_walkers: int = 32
    max_steps: int = 40_000
    progress: bool = False

    def __post_init__(self):
        for name, lowest in (("n_walkers", 2), ("max_steps", 1)):
            value = getattr(self, name)
            whole = isinstance(value, (int, np.integer)) and not isinstance(value, bool)
            if not (whole and value >= lowest):
                raise InputError(f"Sampler({name}={value!r}): give a whole number >= {lowest}")
        object.__setattr__(self, "n_walkers", int(self.n_walkers))
        object.__setattr__(self, "max_steps", int(self.max_steps))
        object.__setattr__(self, "progress", bool(self.progress))


def sampler_of(sampler) -> Sampler:
    """``sampler`` checked: a :class:`Sampler`, or an error naming the argument."""
    if not isinstance(sampler, Sampler):
        raise InputError(
            f"sampler={sampler!r} is not a bayescal.Sampler",
            fix="give e.g. sampler=bayescal.Sampler(n_walkers=64, max_steps=100_000)",
        )
    return sampler
