"""bayescal's parallel steps (:mod:`bayescal._threads`): the threads they take, and the same
numbers whatever that count — the term search's solves and a record's Fourier transforms,
on one thread and on two."""

import contextvars
import json
import time

import numpy as np
import pytest

import bayescal as bc
import bayescal._threads as threads
import bayescal.classical._periodogram as periodogram


def test_the_threads_follow_omp_num_threads_else_the_cores_the_process_may_use(monkeypatch):
    monkeypatch.setenv("OMP_NUM_THREADS", "3")
    assert threads.usable_cores() == 3
    for unset in ("", "0", "two"):
        monkeypatch.setenv("OMP_NUM_THREADS", unset)
        assert threads.usable_cores() == len(threads.os.sched_getaffinity(0))


def test_calls_in_threads_keep_their_order_and_the_callers_context(monkeypatch):
    monkeypatch.setattr(threads, "usable_cores", lambda: 4)
    seen = contextvars.ContextVar("seen", default="none")
    seen.set("caller's")
    assert threads.in_threads(lambda item: (item, seen.get()), range(9)) == [
        (item, "caller's") for item in range(9)
    ]


def test_the_first_failure_in_threads_is_raised_and_no_later_call_starts(monkeypatch):
    monkeypatch.setattr(threads, "usable_cores", lambda: 2)
    started = []

    def call(item):
        started.append(item)
        if item == 1:
            raise ValueError("the second")
        time.sleep(0.01)  # long beside the caller's answer to the failure
        return item

    with pytest.raises(ValueError, match="the second"):
        threads.in_threads(call, range(200))
    assert len(started) < 200


def _fit_on(monkeypatch, count: int, values) -> str:
    monkeypatch.setattr(threads, "usable_cores", lambda: count)
    monkeypatch.setattr(periodogram, "usable_cores", lambda: count)
    fit = bc.fit_noise(values, rate_hz=100.0, seed=2)
    return json.dumps([fit.selection.table, fit.summary], sort_keys=True)


def test_a_fit_with_its_terms_chosen_is_the_same_to_the_bit_on_one_thread_and_two(monkeypatch):
    # White noise and a random walk: the search fits every candidate beside white noise,
    # then beside the walk, each family's solves at once where there are two threads.
    values = bc.NoiseModel(rate_hz=100.0, bias=0.3, N=0.005, K=2e-4).simulate(2**16, seed=5)
    one, two = (_fit_on(monkeypatch, count, values) for count in (1, 2))
    assert one == two
    assert '"rate_random_walk"' in one


def test_a_long_transform_is_the_same_to_the_bit_on_one_thread_and_two(monkeypatch):
    increments = np.random.default_rng(3).standard_normal(2**21)
    taper = periodogram.tukey_window(increments.size, periodogram.TAPER_FRACTION)
    transforms = []
    for count in (1, 2):
        monkeypatch.setattr(periodogram, "usable_cores", lambda count=count: count)
        transforms.append(periodogram.tapered_transform(increments, taper))
    assert transforms[0][0] == transforms[1][0]
    assert np.array_equal(transforms[0][1], transforms[1][1])
