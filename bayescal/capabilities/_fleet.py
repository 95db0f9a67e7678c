"""A fleet of sensors: the noise of each recording, fitted on a Dask cluster or batched on one
JAX device, and the population of the units on top (:mod:`bayescal.inference._population`).
Where the work runs is :mod:`._fleet_tasks`; the specifications a unit is assessed against,
:mod:`._fleet_spec`.

Seeds. The fleet's seed gives each recording its own, from the seed and the recording's data
row (``numpy.random.SeedSequence([seed, 1, row])``), and the population its own
(``[seed, 0]``): the same manifest and seed give the same numbers on any cluster.

Failures. A recording that cannot be read or analysed (bad input), whose posterior failed its
sampler checks, whose model does not fit it (a misfit), or whose task failed (a worker lost
twice) is reported by path with the reason, and the rest go on; the population is fitted from
those that passed. Nothing is written here.

Terms. Every recording is fitted with the same terms, by default the classical three (white,
bias instability, rate random walk), never chosen record by record
(:func:`~bayescal.models._terms.fleet_terms` says why); a recording whose model does not fit
it (its fit checks, :attr:`~bayescal.NoiseFit.checks`) is left out and reported by path like
any other failure (``misfit``).
"""

from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path

import numpy as np

from .._errors import HealthCheckError, InputError
from ..inference._population import (
    Limit,
    PopulationPosterior,
    RecordingDraws,
    fit_population,
    outlier_threshold,
    outliers,
    predictive,
    resolved_parameters,
    spec_probabilities,
)
from ..inference._sampler import Sampler, sampler_of
from ..models._terms import CLASSICAL_TERMS, display_values, fleet_terms, parameter_unit
from ..recording._manifest import Manifest, read_manifest
from ..recording._sensor_cards import SensorCard, find_card
from ._checked import Checked
from ._fleet_spec import assessed_limits, checked_spec
from ._fleet_tasks import RecordingFailure, RecordingTask, run_batched, run_on_cluster


def _interval(draws, unit: str, transform=None) -> dict:
    values = np.ravel(draws) if transform is None else transform(np.ravel(draws))
    return {
        "mean": float(np.mean(values)),
        "q05": float(np.quantile(values, 0.05)),
        "q95": float(np.quantile(values, 0.95)),
        "unit": unit,
    }


def _not_identified(unit: str, why: str) -> dict:
    return {"mean": None, "q05": None, "q95": None, "unit": unit, "note": why}


@dataclass(frozen=True)
class FleetFit(Checked):
    """A fleet's population: the population of its units' noise scales and turn-on bias, each
    unit's estimate shrunk toward it, the next unit's predictive distribution, and the
    probability that a unit meets a specification (:func:`fit_fleet`).

    :attr:`summary` gives every figure with its 90 % interval and unit (the JSON document of
    ``bayescal fleet`` renders it); :attr:`population` is the posterior itself; :meth:`check`
    raises when it failed its checks.
    """

    _check_subject = "population: checks failed"

    source: str
    """The manifest."""
    channel: str
    """The channel fitted in every recording."""
    unit: str
    """The channel's unit, common to the fleet."""
    terms: tuple[str, ...]
    """The noise terms every recording was fitted with."""
    recordings: tuple[RecordingDraws, ...] = field(repr=False)
    """What each recording's fit shipped back (those that passed)."""
    failed: tuple[RecordingFailure, ...]
    """The recordings left out (unreadable, failed sampler checks, a misfit), by path, with
    the reason."""
    population: PopulationPosterior = field(repr=False)
    """The population's posterior: medians and log-sds of the noise scales, the turn-on bias's
    mean and unit-to-unit and run-to-run sds, each unit's shrunk estimate, with checks."""
    limits: tuple[Limit, ...]
    """The specifications asked for (``N<0.3 deg/sqrt(h)``), each in the parameter's unit."""
    compute: dict
    """Where the work ran: scheduler, workers, tasks, and the tasks' times and sizes."""
    seed: int
    """The seed of every fit (the same inputs and seed give the same fleet)."""
    notes: tuple[str, ...] = ()
    """What was inferred or noticed along the way."""

    @property
    def parameters(self) -> tuple[str, ...]:
        """The noise scales the population holds (those the recordings resolve)."""
        return self.population.parameters

    @property
    def units(self) -> tuple[str, ...]:
        """The units' ids in the population, in manifest order."""
        return self.population.units

    @property
    def passed(self) -> bool:
        """Whether the population's posterior passed its checks (the recordings left out are
        in :attr:`failed`)."""
        return self.population.passed

    @property
    def failures(self) -> tuple[str, ...]:
        """The population's failed checks (empty when it passed)."""
        return self.population.failures

    @cached_property
    def predictive(self) -> dict:
        """Draws of the next unit: natural log of each noise scale, and the turn-on bias of
        its first run (empty with one unit)."""
        return predictive(self.population, seed=self.population.seed)

    @cached_property
    def outliers(self) -> dict:
        """unit -> parameter -> two-sided tail probability of its own estimate under the
        population fitted without it (:func:`~bayescal.inference._population.outliers`)."""
        return outliers(self.population)

    @cached_property
    def summary(self) -> dict:
        """``population``, ``units``, ``spec`` (None without limits) and ``outliers``, every
        figure as {mean, q05, q95, unit} (90 % intervals)."""
        return {
            "population": self._population_summary(),
            "units": self._unit_summary(),
            "spec": self._spec_summary(),
            "outliers": self._outlier_summary(),
        }

    def _population_summary(self) -> dict:
        posterior, values, unit = self.population, self.population.values, self.unit
        one_unit = "one unit: no spread across units to estimate"
        summary = {}
        for i, p in enumerate(self.parameters):
            p_unit = parameter_unit(p, unit)
            entry = {}
            if posterior.unit_spread:
                entry["median"] = _interval(values["mu"][:, i], p_unit, np.exp)
                entry["log_sd"] = _interval(values["sigma"][:, i], "1")
                entry["log_sd"]["definition"] = f"sd of ln({p}) across units"
                entry["predictive"] = _interval(self.predictive[p], p_unit, np.exp)
            else:
                only = posterior.units[0]
                entry["median"] = _interval(posterior.unit_draws[only][p], p_unit, np.exp)
                entry["median"]["note"] = f"{one_unit}: the unit's own value"
                entry["log_sd"] = _not_identified("1", one_unit)
                entry["predictive"] = _not_identified(p_unit, one_unit)
            entry["display"] = {
                label: {
                    key: (
                        None
                        if entry["median"][key] is None
                        else display_values(p, entry["median"][key], unit)[label]
                    )
                    for key in ("mean", "q05", "q95")
                }
                for label in display_values(p, 1.0, unit)
            }
            summary[p] = entry
        bias = {"mean": _interval(values["mu_bias"], unit)}
        if posterior.unit_spread:
            bias["unit_to_unit_sd"] = _interval(values["tau_unit"], unit)
            bias["predictive"] = _interval(self.predictive["bias"], unit)
            if not posterior.run_spread:
                bias["unit_to_unit_sd"]["note"] = (
                    "one run per unit: includes the run-to-run spread, which it cannot be told from"
                )
        else:
            bias["mean"]["note"] = f"{one_unit}: the unit's mean turn-on bias"
            bias["unit_to_unit_sd"] = _not_identified(unit, one_unit)
            bias["predictive"] = _not_identified(unit, one_unit)
        if posterior.run_spread:
            bias["run_to_run_sd"] = _interval(values["tau_run"], unit)
        else:
            bias["run_to_run_sd"] = _not_identified(unit, "one run per unit: no repeat to measure")
        summary["bias"] = bias
        return summary

    def _unit_summary(self) -> dict:
        posterior, unit = self.population, self.unit
        by_unit = {}
        for u, name in enumerate(posterior.units):
            own = posterior.own[u]
            draws = posterior.unit_draws[name]
            entry = {}
            for p in self.parameters:
                entry[p] = _interval(draws[p], parameter_unit(p, unit), np.exp)
                entry[p]["own"] = {key: own[p][key] for key in ("mean", "q05", "q95")}
            entry["bias"] = _interval(draws["bias"], unit)
            entry["bias"]["own"] = {key: own["bias"][key] for key in ("mean", "q05", "q95")}
            entry["bias"]["definition"] = "the unit's mean turn-on bias over power-ups"
            runs = [r for r in self.recordings if r.unit == name]
            entry["runs"] = {
                r.run: {
                    "source": r.source,
                    "row": r.row,
                    "bias": own["run_bias"][i],
                    "temperature_c": r.temperature_c,
                }
                for i, r in enumerate(runs)
            }
            by_unit[name] = entry
        return by_unit

    def _spec_summary(self) -> dict | None:
        if not self.limits:
            return None
        probabilities = spec_probabilities(self.population, list(self.limits))
        limits = []
        for i, limit in enumerate(self.limits):
            entry = {
                "parameter": limit.parameter,
                "limit": limit.value,
                "unit": limit.unit,
                "label": limit.label,
                "source": limit.source,
                "display": {}
                if limit.parameter == "bias"
                else display_values(limit.parameter, limit.value, self.unit),
                "next_unit": None
                if probabilities["next_unit"] is None
                else _interval(probabilities["next_unit"][i], "1"),
                "units": {
                    unit: float(np.mean(by_limit[i]))
                    for unit, by_limit in probabilities["units"].items()
                },
            }
            limits.append(entry)
        every = probabilities["next_unit_all"]
        return {
            "limits": limits,
            "all": {
                "next_unit": None if every is None else _interval(every, "1"),
                "units": {
                    unit: float(np.mean(p)) for unit, p in probabilities["units_all"].items()
                },
                "definition": "a unit meets every limit: the population's noise scales and "
                "bias are independent, so the product over parameters of meeting each "
                "parameter's tightest limit",
            },
            "definition": "next_unit: the probability that a unit drawn from the population "
            "meets the limit, with its 90 % interval over the population's posterior; units: "
            "each unit's posterior probability (for the bias, of its next power-up)",
        }

    def _outlier_summary(self) -> dict:
        if not self.outliers:
            return {"threshold": None, "units": {}, "note": "one unit: nothing to compare with"}
        threshold = outlier_threshold(self.population)
        return {
            "threshold": threshold,
            "definition": "two-sided tail probability of the unit's own estimate under the "
            "predictive distribution of the population fitted without it; flagged below "
            "5 % / (units x parameters)",
            "units": {
                unit: {
                    "tail_probability": tails,
                    "flagged": sorted(p for p, value in tails.items() if value < threshold),
                }
                for unit, tails in self.outliers.items()
            },
        }


def _compute(where: dict, n_tasks: int, fitted, sizes: dict) -> dict:
    """Where the work ran (``where``: scheduler, cluster, workers, wall time), the number of
    tasks, and the fitted tasks' times and sizes."""
    seconds = [r.seconds for r in fitted]
    return {
        "scheduler": where["scheduler"],
        "cluster": where["cluster"],
        "workers": where["workers"],
        "tasks": n_tasks,
        "wall_s": where["wall_s"],
        "task_s": {
            "mean": float(np.mean(seconds)),
            "max": float(np.max(seconds)),
            "total": float(np.sum(seconds)),
        },
        "result_bytes": {
            "mean": float(np.mean(list(sizes.values()))),
            "max": int(max(sizes.values())),
        },
    }


def _seed(*key: int) -> int:
    return int(np.random.SeedSequence(list(key)).generate_state(1)[0])


def fit_fleet(
    manifest: str | Path | Manifest,
    channel: str,
    *,
    terms=CLASSICAL_TERMS,
    sensor: str | SensorCard | None = None,
    spec=None,
    seed: int = 0,
    unit: str | None = None,
    scale: float | None = None,
    rate_hz: float | None = None,
    time_column: str | None = None,
    time_unit: str | None = None,
    gaps: str = "error",
    start: float | None = None,
    stop: float | None = None,
    skip_rows: int = 0,
    names=None,
    topic: str | None = None,
    samples_axis: int | None = None,
    channels_axis: int | None = None,
    scheduler=None,
    workers: int | None = None,
    batch: bool | None = None,
    sampler: Sampler = Sampler(),
) -> FleetFit:
    """The population of a fleet of sensors, from each recording's noise posterior.

    Parameters
    ----------
    manifest : str, Path or Manifest
        The fleet's CSV (../shared/DESIGN.md "Fleets": ``path``, ``unit``, optionally
        ``run``, ``rate``, ``temperature``), or one read by :func:`~bayescal.read_manifest`.
    channel : str
        The column every recording is analysed on (e.g. ``gyro_x``).
    terms : str or tuple of str
        Noise terms of every recording's fit (:func:`~bayescal.fit_noise`), the same for
        each (not ``auto``, module docstring); default white, bias instability and rate
        random walk. The population holds N, B and K among them where the
        recordings resolve them; quantization or an output filter, when added, stay each
        recording's own.
    sensor : str or SensorCard, optional
        A sensor card whose datasheet figures become each fit's priors (divided out again by
        the population).
    spec : str, SensorCard, mapping or sequence, optional
        Limits a unit should meet: a sensor card (its datasheet N, B, K; typical values), a
        limit ``"N<0.3 deg/sqrt(h)"`` (N, B, K at or below; ``bias`` in magnitude), a
        sequence of these, or a mapping ``{"N": 0.005, "B": "10 deg/h"}`` (a number is in the
        parameter's unit for the channel).
    seed : int
        The fleet's seed; each recording's and the population's derive from it.
    unit, scale, rate_hz, time_column, time_unit, gaps, start, stop
        How each recording's channel is put on its grid (:meth:`~bayescal.Recording.channel`;
        ``scale`` turns raw counts into ``unit``); a manifest row's ``rate`` overrides
        ``rate_hz``.
    skip_rows, names, topic, samples_axis, channels_axis
        How each file is read (:func:`~bayescal.load_recording`): logger lines before a text
        table's header, the names of a headerless table's or an array's columns, a ROS bag's
        topic, the axes of an N-D array. A long recording (streamed) takes ``skip_rows``
        alone; given the others, it is left out with the reason.
    scheduler : str or distributed.Client, optional
        A Dask scheduler's address (``tcp://host:port``) or a client; None starts a
        ``LocalCluster`` of ``workers`` processes (default: one per core).
    workers : int, optional
        Worker processes of the local cluster.
    batch : bool, optional
        Fit the recordings in this process on JAX's default device, those of one length
        (on their grid) and rate together: one vmapped MAP and one emcee run of all their
        walkers, each recording's paired only among themselves
        (:mod:`bayescal.inference._batched`), where a GPU does hundreds at once. A
        recording alone in its batch, or whose batched posterior failed its sampler checks,
        is fitted alone. False: one Dask task per recording. Default (None): batched when
        JAX's default device is a GPU and neither ``scheduler`` nor ``workers`` is given.
        The two paths' draws differ (random streams), their distributions do not.
    sampler : Sampler
        How every posterior is sampled, each recording's and the population's
        (:class:`~bayescal.Sampler`); its ``progress`` shows a bar over the recordings and
        the population's sampling on stderr.

    Returns
    -------
    FleetFit
        The population, the units, the spec, where the work ran, and the recordings left out.

    Raises
    ------
    InputError
        A bad manifest or option (before any work), a fleet of one recording, a spec whose
        unit does not fit the channel, or batched fits asked for with a scheduler or workers.
    HealthCheckError
        Fewer than two recordings passed.

    Examples
    --------
    >>> import bayescal as bc
    >>> fleet = bc.fit_fleet("fleet.csv", "gyro_x", unit="deg/s", workers=2)  # doctest: +SKIP
    >>> fleet.summary["population"]["N"]["median"]  # doctest: +SKIP
    {'mean': 0.0041, 'q05': 0.0038, 'q95': 0.0044, 'unit': 'deg/s/sqrt(Hz)', ...}
    """
    manifest = manifest if isinstance(manifest, Manifest) else read_manifest(manifest)
    if len(manifest.rows) < 2:
        raise InputError(
            "a fleet needs at least two recordings", source=manifest.source, fix="add rows"
        )
    terms = fleet_terms(terms)
    sampler = sampler_of(sampler)
    if isinstance(sensor, str):
        sensor = find_card(sensor)
    requested, card = checked_spec(spec, terms, unit)
    grid = {
        "unit": unit,
        "scale": scale,
        "time_column": time_column,
        "time_unit": time_unit,
        "gaps": gaps,
        "start": start,
        "stop": stop,
    }
    reading = {
        "skip_rows": skip_rows,
        "names": names,
        "topic": topic,
        "samples_axis": samples_axis,
        "channels_axis": channels_axis,
    }
    tasks = [
        RecordingTask(
            row=row.row,
            path=str(row.path),
            unit=row.unit,
            run=row.run,
            channel=channel,
            grid={**grid, "rate_hz": row.rate_hz or rate_hz},
            terms=terms,
            sensor=sensor,
            seed=_seed(seed, 1, row.row),
            sampler=replace(sampler, progress=False),
            temperature_c=row.temperature_c,
            reading=reading,
        )
        for row in manifest.rows
    ]
    if batch is None:
        import jax

        batch = jax.default_backend() == "gpu" and scheduler is None and workers is None
    if batch and (scheduler is not None or workers is not None):
        raise InputError(
            "batched fits run in this process on JAX's default device: scheduler= and "
            "workers= are for one task per recording",
            fix="leave scheduler= and workers= out, or fit one task per recording",
        )
    if batch:
        results, sizes, where = run_batched(tasks, sampler.progress)
    else:
        results, sizes, where = run_on_cluster(tasks, scheduler, workers, sampler.progress)
    fitted = [r for r in results if isinstance(r, RecordingDraws)]
    failed = tuple(r for r in results if isinstance(r, RecordingFailure))
    if len(fitted) < 2:
        listing = "; ".join(f"{f.source}: {f.message}" for f in failed)
        raise HealthCheckError(
            f"{manifest.source}: {len(fitted)} of {len(results)} recordings passed, a population "
            f"needs two: {listing}"
        )
    fleet_unit = fitted[0].channel_unit
    fitted = [r.in_unit(fleet_unit) for r in fitted]
    parameters, notes = resolved_parameters(fitted)
    assessed, unassessed = assessed_limits(requested, card, fleet_unit, parameters)
    posterior = fit_population(
        fitted,
        parameters,
        seed=_seed(seed, 0),
        sampler=sampler,
    )
    return FleetFit(
        source=manifest.source,
        channel=channel,
        unit=fleet_unit,
        terms=terms,
        recordings=tuple(fitted),
        failed=failed,
        population=posterior,
        limits=tuple(assessed),
        compute=_compute(where, len(tasks), fitted, sizes),
        seed=seed,
        notes=(*notes, *unassessed),
    )
