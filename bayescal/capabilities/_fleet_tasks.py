"""Where a fleet's work runs (:func:`~bayescal.fit_fleet`). Each recording's load and noise
fit is one Dask task (:func:`fit_recording`); it ships back only what the population needs
(:class:`~bayescal.inference._population.RecordingDraws`: about 80 kB, where the fit holds
the record's spectral and level summaries too), or the reason it cannot be used
(:class:`RecordingFailure`). With no scheduler a ``LocalCluster`` of one single-threaded
worker process per core (or ``workers``) runs them; with an address (``tcp://host:port``) an
existing cluster does, through the same code; an existing ``distributed.Client`` may be passed
too. The workers read the recordings themselves, so a remote cluster needs the manifest's
files at the same paths (a shared file system) and the same bayescal (checked before any task
is sent). Batched (:func:`run_batched`), the recordings are read in this process instead and
those of one length and rate fitted together on JAX's default device."""

import contextlib
import os
import pickle
import signal
import sys
import threading
import time
from dataclasses import dataclass, field
from importlib.metadata import version

import numpy as np

from .._caches import release_compiled_code
from .._errors import BayescalError, InputError
from ..inference._population import RecordingDraws
from ..inference._sampler import Sampler
from ..recording._sensor_cards import SensorCard

CONNECT_TIMEOUT_S = 30


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
    sampler: Sampler
    """How the recording's posterior is sampled (no progress bar: the fleet has its own)."""
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
    release_compiled_code()
    from ._noise import fit_noise

    started = time.perf_counter()
    try:
        fit = fit_noise(
            _channel(task),
            terms=task.terms,
            sensor=task.sensor,
            seed=task.seed,
            sampler=task.sampler,
        )
    except BayescalError as error:
        return _failure(task, error)
    return _judged(fit, task, time.perf_counter() - started)


def _channel(task: RecordingTask):
    """The task's channel on its grid, read whole or streamed (a long recording: a worker's
    memory bounded by a block, as noise's)."""
    from ..recording._recording import load_recording
    from ..recording._stream import is_long_recording, stream_channel

    if is_long_recording(task.path):
        _refuse_unstreamed(task)
        skip_rows = task.reading.get("skip_rows", 0)
        return stream_channel(task.path, task.channel, skip_rows=skip_rows, **task.grid)
    return load_recording(task.path, **task.reading).channel(task.channel, **task.grid)


def _failure(task: RecordingTask, error: BayescalError) -> RecordingFailure:
    kind = "input" if isinstance(error, InputError) else "health"
    return RecordingFailure(task.row, task.path, task.unit, task.run, kind, str(error))


def _judged(fit, task: RecordingTask, seconds: float) -> RecordingDraws | RecordingFailure:
    """What the population takes of a recording's fit: its draws, or why it is left out."""
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
    return recording_draws(fit, task, seconds)


def run_batched(tasks, progress: bool):
    """Every task in this process, the recordings of one length, rate and problem structure
    fitted together on JAX's default device (:func:`~bayescal.inference._batched.
    sample_noise_each`: one vmapped MAP and one emcee run per batch), in row order, with the
    size of each result and where the work ran. A recording alone in its batch, or whose
    batched posterior failed its sampler checks (a stuck run, which the batch does not
    restart), is sampled alone as a Dask task samples it (:func:`_fit_alone`, from what was
    already read and summarised)."""
    release_compiled_code()
    import jax

    from ..inference._batched import sample_noise_each
    from ._noise import finish_noise, prepare_noise

    started = time.perf_counter()
    results, batches = {}, {}
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(tasks), desc="fleet (recordings)", unit="rec", file=sys.stderr)
    for task in tasks:
        begun = time.perf_counter()
        try:
            front = prepare_noise(_channel(task), terms=task.terms, sensor=task.sensor)
        except BayescalError as error:
            results[task.row] = _failure(task, error)
            if bar is not None:
                bar.update(1)
            continue
        shaped = front.problem.for_likelihood()
        key = (
            front.data.rate_hz,
            front.data.values.size,
            jax.tree.structure(shaped),
            tuple(np.shape(leaf) for leaf in jax.tree.leaves(shaped)),
        )
        batches.setdefault(key, []).append((task, front, time.perf_counter() - begun))
    for batch in batches.values():
        alone = list(batch) if len(batch) == 1 else []
        if not alone:
            begun = time.perf_counter()
            sampler = batch[0][0].sampler
            posteriors = sample_noise_each(
                [front.problem for _, front, _ in batch],
                names=[task.path for task, _, _ in batch],
                terms=batch[0][0].terms,
                seeds=[task.seed for task, _, _ in batch],
                n_walkers=sampler.n_walkers,
                max_steps=sampler.max_steps,
            )
            share = (time.perf_counter() - begun) / len(batch)
            for (task, front, own), posterior in zip(batch, posteriors, strict=True):
                if not posterior.diagnostics.passed:
                    alone.append((task, front, own))
                    continue
                fit = finish_noise(front, posterior, task.seed)
                results[task.row] = _judged(fit, task, own + share)
                if bar is not None:
                    bar.update(1)
        for task, front, own in alone:
            results[task.row] = _fit_alone(task, front, own)
            if bar is not None:
                bar.update(1)
    if bar is not None:
        bar.close()
    ordered = [results[task.row] for task in tasks]
    sizes = {r.row: len(pickle.dumps(r)) for r in ordered}
    sizes_of_batches = ", ".join(str(len(batch)) for batch in batches.values())
    where = {
        "scheduler": f"JAX device {jax.devices()[0]}",
        "cluster": f"batched fits in this process (batches of {sizes_of_batches} recordings)",
        "workers": 1,
        "wall_s": time.perf_counter() - started,
    }
    return ordered, sizes, where


def _fit_alone(task: RecordingTask, front, seconds: float) -> RecordingDraws | RecordingFailure:
    """A recording's posterior sampled on its own (with the restarts of a stuck run) from its
    :func:`~._noise.prepare_noise`: what :func:`fit_recording` computes, without reading and
    summarising the recording again; ``seconds`` already spent on it."""
    from ..inference._noise_posterior import sample_noise
    from ._noise import finish_noise

    started = time.perf_counter()
    try:
        posterior = sample_noise(
            front.problem,
            terms=front.terms,
            seed=task.seed,
            n_walkers=task.sampler.n_walkers,
            max_steps=task.sampler.max_steps,
        )
        fit = finish_noise(front, posterior, task.seed)
    except BayescalError as error:
        return _failure(task, error)
    return _judged(fit, task, seconds + time.perf_counter() - started)


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


def client_of(scheduler, workers: int | None):
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
            "workers= sets the size of a local cluster; with scheduler= the cluster's own "
            "workers run the tasks",
            fix="leave workers= out",
        )
    if isinstance(scheduler, Client):
        return scheduler, None, "client"
    try:
        client = Client(str(scheduler), timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError, ValueError) as error:
        raise InputError(
            f"scheduler={str(scheduler)!r}: cannot connect ({error})",
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


def check_workers(client, address: str) -> int:
    """The number of workers, after checking that each runs this bayescal."""
    try:
        client.wait_for_workers(1, timeout=CONNECT_TIMEOUT_S)
    except TimeoutError:
        raise InputError(
            f"scheduler={address!r}: no worker joined within {CONNECT_TIMEOUT_S} s",
            fix="start workers (dask worker ADDRESS)",
        ) from None
    try:
        versions = client.run(worker_version)
    except Exception as error:  # an unpicklable function: bayescal missing on a worker
        raise InputError(
            f"scheduler={address!r}: the workers cannot run bayescal ({type(error).__name__}: "
            f"{error})",
            fix="install the same bayescal on every worker",
        ) from None
    mine = version("bayescal")
    other = {worker: v for worker, v in versions.items() if v != mine}
    if other:
        raise InputError(
            f"scheduler={address!r}: workers run bayescal {sorted(set(other.values()))}, "
            f"this client {mine}",
            fix="install the same bayescal on every worker",
        )
    return len(versions)


def run_tasks(client, tasks, progress: bool):
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


def run_on_cluster(tasks, scheduler, workers: int | None, progress: bool):
    """Every task on the cluster (:func:`client_of`), in row order, with the size of each
    result and where the work ran (scheduler, cluster, workers, wall time)."""
    started = time.perf_counter()
    client, cluster, kind = client_of(scheduler, workers)
    try:
        address = client.scheduler.address
        worker_count = check_workers(client, address)
        results, sizes = run_tasks(client, tasks, progress)
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
    where = {
        "scheduler": address,
        "cluster": {
            "local": "LocalCluster started for this fleet",
            "remote": "existing cluster",
            "client": "existing client",
        }[kind],
        "workers": worker_count,
        "wall_s": time.perf_counter() - started,
    }
    return results, sizes, where
