"""A fleet of sensors: the noise of each recording, fitted on a Dask cluster, and the
population of the units on top (:mod:`bayescal.inference._population`).

Where the work runs. Each recording's load and noise fit is one Dask task
(:func:`fit_recording`); it ships back only what the population needs
(:class:`~bayescal.inference._population.RecordingDraws`: about 80 kB, where the fit holds
the record's spectral and level summaries too). With no scheduler a ``LocalCluster`` of one
single-threaded worker process per core (or ``workers``) runs them; with an address
(``tcp://host:port``) an existing cluster does, through the same code; an existing
``distributed.Client`` may be passed too. The workers read the recordings themselves, so a
remote cluster needs the manifest's files at the same paths (a shared file system) and the
same bayescal (checked before any task is sent). The population is fitted on the client.

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

import contextlib
import math
import os
import pickle
import re
import signal
import sys
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from importlib.metadata import version
from pathlib import Path

import numpy as np

from .._errors import BayescalError, HealthCheckError, InputError
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
from ..models._noise_model import parameter_unit
from ..models._terms import CLASSICAL_TERMS, PARAMETERS_OF_TERM, TERM_OF_PARAMETER, fleet_terms
from ..recording._manifest import Manifest, read_manifest
from ..recording._sensor_cards import SensorCard, find_card
from ..recording._units import card_value_in, display_values, parse_unit

SPEC_PARAMETERS = ("N", "B", "K", "bias")
CONNECT_TIMEOUT_S = 30
_LIMIT = re.compile(r"\s*(\w+)\s*<=?\s*([-+]?[0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*(.*?)\s*")


@dataclass(frozen=True)
class RecordingTask:
    """One recording to fit: everything a worker needs, and nothing it must look up."""

    row: int
    path: str
    unit: str
    run: str
    channel: str
    grid: dict
    """How the channel is put on its grid (:meth:`~bayescal.Recording.channel`'s options)."""
    terms: tuple[str, ...]
    sensor: SensorCard | None
    seed: int
    n_walkers: int
    max_steps: int
    temperature_c: float | None = None
    reading: dict = field(default_factory=dict)
    """How the file is read (:func:`~bayescal.load_recording`'s options: ``skip_rows``,
    ``names``, ``topic``, ``samples_axis``, ``channels_axis``)."""


@dataclass(frozen=True)
class RecordingFailure:
    """A recording left out of the population, and why."""

    row: int
    source: str
    unit: str
    run: str
    kind: str
    """``input`` (cannot be read or analysed as given), ``health`` (its posterior failed its
    sampler checks), ``misfit`` (the fitted model does not fit the record: its Allan deviation,
    spectrum or lag-1 autocorrelation checks failed, :attr:`~bayescal.NoiseFit.checks`) or
    ``task`` (its task failed: a worker lost, an internal error)."""
    message: str


def recording_draws(fit, task: RecordingTask, seconds: float) -> RecordingDraws:
    """What the population needs of a :class:`~bayescal.NoiseFit`."""
    problem = fit.fit.problem
    prior = problem.prior
    fitted = [p for p in ("N", "B", "K") if p in problem.parameters]
    index = {p: problem.parameters.index(p) for p in fitted}
    bias_mean, bias_sd = (np.ravel(value) for value in fit.fit.bias_conditional)
    diagnostics = fit.diagnostics
    return RecordingDraws(
        source=fit.source,
        unit=task.unit,
        run=task.run,
        channel=fit.channel,
        channel_unit=fit.unit,
        rate_hz=fit.rate_hz,
        n_samples=fit.classical.n_samples,
        terms=fit.terms,
        log_draws={p: np.log(np.ravel(fit.draws[p])) for p in fitted},
        prior_location={p: float(prior.location[i]) for p, i in index.items()},
        prior_scale={p: float(prior.scale[i]) for p, i in index.items()},
        bias_mean=bias_mean,
        bias_sd=bias_sd,
        prior=prior.description,
        seed=task.seed,
        passed=fit.passed,
        failures=fit.failures,
        checks={
            "n_steps": diagnostics.n_steps,
            "n_walkers": diagnostics.n_walkers,
            "max_rhat": max(diagnostics.rhat.values()),
            "min_ess_bulk": min(diagnostics.ess_bulk.values()),
            "acceptance_fraction": diagnostics.acceptance_fraction,
        },
        notes=fit.notes,
        row=task.row,
        temperature_c=task.temperature_c,
        seconds=seconds,
    )


def fit_recording(task: RecordingTask) -> RecordingDraws | RecordingFailure:
    """One Dask task: load a recording, fit its channel's noise, keep what the population
    needs; a recording that cannot be used comes back as a :class:`RecordingFailure`."""
    from ..recording._recording import load_recording
    from ..recording._stream import is_long_recording, stream_channel
    from ._noise import fit_noise

    started = time.perf_counter()
    try:
        if is_long_recording(task.path):  # a worker's memory bounded by a block, as noise's
            _refuse_unstreamed(task)
            skip_rows = task.reading.get("skip_rows", 0)
            channel = stream_channel(task.path, task.channel, skip_rows=skip_rows, **task.grid)
        else:
            channel = load_recording(task.path, **task.reading).channel(task.channel, **task.grid)
        fit = fit_noise(
            channel,
            terms=task.terms,
            sensor=task.sensor,
            seed=task.seed,
            n_walkers=task.n_walkers,
            max_steps=task.max_steps,
        )
    except BayescalError as error:
        kind = "input" if isinstance(error, InputError) else "health"
        return RecordingFailure(task.row, task.path, task.unit, task.run, kind, str(error))
    if not fit.diagnostics.passed:
        return RecordingFailure(
            task.row,
            task.path,
            task.unit,
            task.run,
            "health",
            "posterior checks failed: " + "; ".join(fit.failures),
        )
    if not fit.fits:
        return RecordingFailure(
            task.row,
            task.path,
            task.unit,
            task.run,
            "misfit",
            f"the model ({', '.join(fit.terms)}) does not fit the record: "
            + "; ".join(fit.misfits),
        )
    return recording_draws(fit, task, time.perf_counter() - started)


def _refuse_unstreamed(task: RecordingTask) -> None:
    """A long recording is streamed (a Parquet file or a text table, read in blocks): the
    options of arrays, bags and headerless tables do not apply to it."""
    given = [
        name
        for name in ("names", "topic", "samples_axis", "channels_axis")
        if task.reading.get(name) is not None
    ]
    if given:
        raise InputError(
            f"{given[0]} does not apply to a long recording, which is streamed (read in blocks)",
            source=task.path,
            fix="leave it out: a streamed file is a Parquet file or a text table with a "
            "header line",
        )


def worker_version() -> str:
    """The bayescal a worker runs (checked against the client's before any task)."""
    return version("bayescal")


# ---------------------------------------------------------------------------------------------
# Specifications


@dataclass(frozen=True)
class _Requested:
    parameter: str
    value: float
    unit: str | None
    label: str


def _requested_limits(spec) -> tuple[list[_Requested], SensorCard | None]:
    """Parse ``spec`` (see :func:`fit_fleet`) into limits still in the user's units and at
    most one sensor card; checked before any work."""
    if spec is None:
        return [], None
    if isinstance(spec, (str, SensorCard)):
        spec = [spec]
    items = list(spec.items()) if isinstance(spec, Mapping) else list(spec)
    limits, card = [], None
    for item in items:
        if isinstance(item, SensorCard) or (isinstance(item, str) and "<" not in item):
            if card is not None:
                raise InputError("spec: give at most one sensor card")
            card = item if isinstance(item, SensorCard) else find_card(item)
            continue
        if isinstance(item, str):
            match = _LIMIT.fullmatch(item)
            if match is None:
                raise InputError(
                    f"spec: '{item}' is not PARAMETER<VALUE UNIT",
                    fix="write it like 'N<0.3 deg/sqrt(h)', 'B<10 deg/h' or 'bias<0.5 deg/s'",
                )
            name, value, unit, label = match[1], float(match[2]), match[3] or None, item.strip()
        else:
            name, given = item
            text = str(given).strip()
            parts = text.split(maxsplit=1)
            try:
                value = float(parts[0])
            except (ValueError, IndexError):
                raise InputError(
                    f"spec: {name}={given!r} is not VALUE [UNIT]",
                    fix="give a number in the parameter's unit, or 'VALUE UNIT'",
                ) from None
            unit = parts[1] if len(parts) > 1 else None
            label = f"{name}<{text}"
        if name not in SPEC_PARAMETERS:
            raise InputError(
                f"spec: unknown parameter '{name}'",
                fix=f"limits apply to {', '.join(SPEC_PARAMETERS)}",
            )
        if not (value > 0 and math.isfinite(value)):
            raise InputError(f"spec: the limit of {name} must be a positive number ({value})")
        limits.append(_Requested(name, value, unit, label))
    return limits, card


_FAMILY = {"angle": "angular_rate", "velocity": "acceleration"}


def _check_family(unit: str, channel_unit: str) -> None:
    """A noise figure's unit (deg/sqrt(h), ug/sqrt(Hz) ...) must belong to the channel's kind
    of sensor: a gyro's limit in ug is a mistake, not a conversion."""
    base = parse_unit(re.split(r"[/*]sqrt", unit)[0])
    channel = parse_unit(channel_unit)
    if base.known and channel.known:
        quantity = _FAMILY.get(base.quantity, base.quantity)
        if quantity != channel.quantity:
            raise ValueError(
                f"'{unit}' is a unit of {quantity.replace('_', ' ')}, the channel's "
                f"{channel_unit} of {channel.quantity.replace('_', ' ')}"
            )


def _limit_in(requested: _Requested, channel_unit: str) -> Limit:
    """A requested limit in the parameter's unit for the fleet's channel."""
    name = requested.parameter
    target = parameter_unit(name, channel_unit)
    value = requested.value
    if requested.unit is not None and requested.unit != target:
        try:
            if name == "bias":
                have, want = parse_unit(requested.unit), parse_unit(channel_unit)
                if not (have.known and want.known and have.quantity == want.quantity):
                    raise ValueError(f"'{requested.unit}' is not a unit of {channel_unit}")
                value = value * have.to_si / want.to_si
            else:
                _check_family(requested.unit, channel_unit)
                value = card_value_in(name, value, requested.unit, channel_unit)
        except ValueError as error:
            raise InputError(
                f"spec '{requested.label}': {error}",
                fix=f"give {name} in {target} or a datasheet unit of this kind of channel",
            ) from None
    shown = "|bias|" if name == "bias" else name
    label = f"{shown} < {requested.value:g} {requested.unit or target}"
    return Limit(name, value, target, f"given: {requested.label}", label)


def _card_limits(card: SensorCard, channel_unit: str) -> list[Limit]:
    try:
        values = card.datasheet_values(channel_unit)
    except (InputError, ValueError) as error:
        raise InputError(f"spec {card.name}: {error}") from None
    limits = []
    for p, (value, source) in values.items():
        unit = parameter_unit(p, channel_unit)
        shown = ", ".join(
            f"{v:.3g} {label}" for label, v in display_values(p, value, channel_unit).items()
        )
        limits.append(
            Limit(
                p,
                value,
                unit,
                f"{card.name} datasheet ({card.datasheet}), {source}: a typical value",
                f"{p} <= {value:.4g} {unit}" + (f" ({shown})" if shown else ""),
            )
        )
    return limits


# ---------------------------------------------------------------------------------------------
# The result


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
class FleetFit:
    """A fleet's population: the population of its units' noise scales and turn-on bias, each
    unit's estimate shrunk toward it, the next unit's predictive distribution, and the
    probability that a unit meets a specification (:func:`fit_fleet`).

    :attr:`summary` gives every figure with its 90 % interval and unit (the JSON document of
    ``bayescal fleet`` renders it); :attr:`population` is the posterior itself; :meth:`check`
    raises when it failed its checks.
    """

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

    def check(self) -> "FleetFit":
        """Raise :class:`~bayescal.HealthCheckError` naming the failed checks, if any.

        Returns
        -------
        FleetFit
            This result, unchanged, when every check passed, so that the call chains
            (``result = capability(...).check()``).

        Raises
        ------
        HealthCheckError
            A check failed; the message names each.
        """
        if not self.passed:
            raise HealthCheckError("population: checks failed: " + "; ".join(self.failures))
        return self

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


# ---------------------------------------------------------------------------------------------
# The cluster


@contextlib.contextmanager
def _sigint_ignored():
    """SIGINT ignored while the block runs (in the main thread; elsewhere left as it is)."""
    try:
        before = signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)


def _client(scheduler, workers: int | None):
    """A Dask client: on a new LocalCluster (scheduler None), an existing cluster (an
    address), or the client given. Returns it, whether to close it, and how it is called."""
    import logging
    import warnings

    from distributed import Client, LocalCluster

    if scheduler is None:
        count = workers or os.cpu_count() or 1
        # The worker processes ignore SIGINT: Ctrl-C at a terminal reaches every process of
        # its group, and this one alone answers it, closing the cluster (workers of their own
        # printed tracebacks). A process inherits an ignored signal only from an ignoring
        # parent, so this one ignores it while they start.
        with _sigint_ignored(), warnings.catch_warnings():
            # The scheduler's HTTP endpoint moving off a busy port is no news to a user.
            warnings.filterwarnings("ignore", "Port .* is already in use")
            cluster = LocalCluster(
                n_workers=count,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.ERROR,
            )
        try:
            return Client(cluster), cluster, "local"
        except BaseException:  # an interruption too: the caller has no cluster to close
            cluster.close()
            raise
    if workers is not None:
        raise InputError(
            "--workers sets the size of a local cluster; with --scheduler the cluster's own "
            "workers run the tasks",
            fix="leave --workers out",
        )
    if isinstance(scheduler, Client):
        return scheduler, None, "client"
    try:
        client = Client(str(scheduler), timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError, ValueError) as error:
        raise InputError(
            f"--scheduler {scheduler}: cannot connect ({error})",
            fix="give the address of a running Dask scheduler, e.g. tcp://host:8786",
        ) from None
    return client, None, "remote"


def _quiet_workers(client) -> None:
    """Silence a local cluster's workers before it closes under them mid-task (an error, an
    interruption): each would log the scheduler's going away as an error with its traceback,
    on this process's terminal. At most 2 s; a worker that does not answer is closed as is."""
    import logging

    def silence():
        with contextlib.suppress(Exception):
            client.run(logging.disable, logging.CRITICAL)

    thread = threading.Thread(target=silence, daemon=True)
    thread.start()
    thread.join(2.0)


def _check_workers(client, address: str) -> int:
    """The number of workers, after checking that each runs this bayescal."""
    try:
        client.wait_for_workers(1, timeout=CONNECT_TIMEOUT_S)
    except TimeoutError:
        raise InputError(
            f"--scheduler {address}: no worker joined within {CONNECT_TIMEOUT_S} s",
            fix="start workers (dask worker ADDRESS)",
        ) from None
    try:
        versions = client.run(worker_version)
    except Exception as error:  # an unpicklable function: bayescal missing on a worker
        raise InputError(
            f"--scheduler {address}: the workers cannot run bayescal ({type(error).__name__}: "
            f"{error})",
            fix="install the same bayescal on every worker",
        ) from None
    mine = version("bayescal")
    other = {worker: v for worker, v in versions.items() if v != mine}
    if other:
        raise InputError(
            f"--scheduler {address}: workers run bayescal {sorted(set(other.values()))}, "
            f"this client {mine}",
            fix="install the same bayescal on every worker",
        )
    return len(versions)


def _run_tasks(client, tasks, progress: bool):
    """Submit every task, collect every result in row order; a failed task becomes a
    :class:`RecordingFailure`."""
    from distributed import as_completed

    futures = {client.submit(fit_recording, task, pure=False, retries=1): task for task in tasks}
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(tasks), desc="fleet (recordings)", unit="rec", file=sys.stderr)
    results, sizes = {}, {}
    try:
        for future in as_completed(futures):
            task = futures[future]
            if future.status == "error":
                error = future.exception()
                results[task.row] = RecordingFailure(
                    task.row,
                    task.path,
                    task.unit,
                    task.run,
                    "task",
                    f"{type(error).__name__}: {error}",
                )
            else:
                result = future.result()
                sizes[task.row] = len(pickle.dumps(result))
                results[task.row] = result
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
        client.cancel(list(futures))
    return [results[task.row] for task in tasks], sizes


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
    rate: float | None = None,
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
    n_walkers: int = 32,
    max_steps: int = 40_000,
    progress: bool = False,
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
    unit, scale, rate, time_column, time_unit, gaps, start, stop
        How each recording's channel is put on its grid (:meth:`~bayescal.Recording.channel`;
        ``scale`` turns raw counts into ``unit``); a manifest row's ``rate`` overrides
        ``rate``.
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
    n_walkers, max_steps : int
        emcee settings of every posterior (each recording's and the population's).
    progress : bool
        A progress bar over the recordings on stderr.

    Returns
    -------
    FleetFit
        The population, the units, the spec, where the work ran, and the recordings left out.

    Raises
    ------
    InputError
        A bad manifest or option (before any work), a fleet of one recording, or a spec whose
        unit does not fit the channel.
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
    if isinstance(sensor, str):
        sensor = find_card(sensor)
    requested, card = _requested_limits(spec)
    fitted_parameters = {p for term in terms for p in PARAMETERS_OF_TERM[term]}
    for limit in requested:
        if limit.parameter != "bias" and limit.parameter not in fitted_parameters:
            raise InputError(
                f"spec '{limit.label}': {limit.parameter} is not among the fitted terms "
                f"({', '.join(terms)})",
                fix=f"add {TERM_OF_PARAMETER[limit.parameter]} to the terms, or leave it out",
            )
    if unit is not None:  # the limits' units are checked before any work when they can be
        for limit in requested:
            _limit_in(limit, parse_unit(unit).name)
        if card is not None:
            _card_limits(card, parse_unit(unit).name)
    grid = {
        "unit": unit,
        "scale": scale,
        "time_column": time_column,
        "time_unit": time_unit,
        "gaps": gaps,
        "start": start,
        "stop": stop,
    }
    tasks = [
        RecordingTask(
            row=row.row,
            path=str(row.path),
            unit=row.unit,
            run=row.run,
            channel=channel,
            grid={**grid, "rate": row.rate_hz or rate},
            terms=terms,
            sensor=sensor,
            seed=_seed(seed, 1, row.row),
            n_walkers=n_walkers,
            max_steps=max_steps,
            temperature_c=row.temperature_c,
            reading={
                "skip_rows": skip_rows,
                "names": names,
                "topic": topic,
                "samples_axis": samples_axis,
                "channels_axis": channels_axis,
            },
        )
        for row in manifest.rows
    ]
    started = time.perf_counter()
    client, cluster, kind = _client(scheduler, workers)
    try:
        address = client.scheduler.address
        worker_count = _check_workers(client, address)
        results, sizes = _run_tasks(client, tasks, progress)
        worker_count = max(worker_count, len(client.nthreads()))
    except BaseException:
        if kind == "local":
            _quiet_workers(client)
        raise
    finally:
        if kind != "client":
            client.close()
        if cluster is not None:
            cluster.close()
    elapsed = time.perf_counter() - started
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
    limits = [_limit_in(r, fleet_unit) for r in requested]
    if card is not None:
        limits += _card_limits(card, fleet_unit)
    parameters, notes = resolved_parameters(fitted)
    assessed = [limit for limit in limits if limit.parameter in (*parameters, "bias")]
    notes += [
        f"spec {limit.label}: {limit.parameter} has no population here (not fitted, or not "
        "resolved by the recordings): not assessed"
        for limit in limits
        if limit not in assessed
    ]
    posterior = fit_population(
        fitted,
        parameters,
        seed=_seed(seed, 0),
        n_walkers=n_walkers,
        max_steps=max_steps,
        progress=progress,
    )
    seconds = [r.seconds for r in fitted]
    compute = {
        "scheduler": address,
        "cluster": {
            "local": "LocalCluster started for this fleet",
            "remote": "existing cluster",
            "client": "existing client",
        }[kind],
        "workers": worker_count,
        "tasks": len(tasks),
        "wall_s": elapsed,
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
    return FleetFit(
        source=manifest.source,
        channel=channel,
        unit=fleet_unit,
        terms=terms,
        recordings=tuple(fitted),
        failed=failed,
        population=posterior,
        limits=tuple(assessed),
        compute=compute,
        seed=seed,
        notes=tuple(notes),
    )
