"""The filter consistency check in small (benchmarks/filter_consistency.py is the full study):
a MEMS IMU with flicker on a moving vehicle with position fixes; a filter told the white noise
and the bias's walk as bc.filter_noise makes them (the bias instability bounded over the
horizon that follows from the filter's aiding) has the covariance of its errors, one told the
bare Allan-line values is overconfident."""

import math

import numpy as np
import pytest
from _benchmarks import load_benchmark

from bayescal.classical._noise import classical_noise
from bayescal.models._noise_model import NoiseModel
from bayescal.models._terms import TERMS, bounding_walk_variance
from bayescal.navigation._aiding import Aiding, aided_horizon
from bayescal.navigation._consistency import (
    Scenario,
    filter_model,
    nees_band,
    scores,
    setup,
    simulate_runs,
)

RATE = 50.0


MEMS = load_benchmark("filter_consistency").GRADES[
    "MEMS"
]  # the benchmark's MEMS unit, its output filter too


def _exported(truth: dict, sensor: str, scenario: Scenario) -> tuple[float, float]:
    """N and the walk bounding K and B over the horizon the drive's fixes give the sensor."""
    aiding = Aiding("position", scenario.fix_sd_m, scenario.fix_interval_s)

    def deviation(tau: float) -> float:
        return math.sqrt(TERMS["bias_instability"].allan_variance(tau, truth, RATE))

    horizon = aided_horizon(aiding, sensor, deviation, shortest_s=3 / RATE)
    walk = truth["K"] ** 2 + bounding_walk_variance("bias_instability", truth, horizon, RATE)
    return truth["N"], math.sqrt(walk)


def _allan_line(truth: dict, seed: int) -> tuple[float, float]:
    record = NoiseModel(rate_hz=RATE, **truth).simulate(round(1800 * RATE), seed=seed)
    readings = classical_noise(record, RATE).slope_readings
    return readings["N"].value, readings["K"].value


@pytest.fixture(scope="module")
def drives():
    scenario = Scenario(duration_s=300.0, rate_hz=RATE)
    prepared = setup(scenario)
    truth, fixes = simulate_runs(prepared, MEMS, runs=8, seed=3)
    return prepared, truth, fixes


def _inside(drives, white, walk):
    prepared, truth, fixes = drives
    model, scale = filter_model(prepared, MEMS, white, walk)
    nees, _ = scores(model, scale, truth, fixes)
    low, high = nees_band(model, 200, seed=11)
    return np.mean((nees >= low) & (nees <= high)), np.mean(nees > high)


def test_exported_values_make_a_consistent_filter(drives):
    scenario = drives[0].scenario
    gyro = _exported(MEMS.gyro, "gyroscope", scenario)
    accel = _exported(MEMS.accel, "accelerometer", scenario)
    inside, _ = _inside(drives, (gyro[0], accel[0]), (gyro[1], accel[1]))
    assert inside >= 0.75


def test_the_bare_allan_line_makes_an_overconfident_filter(drives):
    gyro, accel = _allan_line(MEMS.gyro, 1), _allan_line(MEMS.accel, 2)
    _, above = _inside(drives, (gyro[0], accel[0]), (gyro[1], accel[1]))
    assert above >= 0.75
