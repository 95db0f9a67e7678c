"""In-field update of a thermal calibration: does the updated calibration beat the old lab
calibration and a fresh fit of the field data alone, at the temperatures the field data do not
cover? And do its 90 % bands cover the truth there?

    python benchmarks/thermal_update.py [--scenarios 20]

Each scenario: a lab warm-up from 20 to 45 degC (30 min at 10 Hz) calibrates a quadratic
thermal bias; since then the sensor has aged (its bias and slope moved: by 4-7 of the lab
calibration's own standard deviations, which describe the lab data, not the aging); in the
field six alignment periods of 2 min between 30 and 36 degC, each with an offset measured to
1 mdeg/s, update the calibration. Bias errors are scored on 20-30 and 36-45 degC.

The update is the library's (as ``bayescal thermal update`` runs it): the lab calibration is
the prior plus a drift since then whose scale is learned (``drift="auto"``). For comparison,
the same update taking the lab calibration as exact (``drift=None``, ``--drift 0``): it wins
on RMSE too, but its bands inherit the lab calibration's confidence and miss the aging.
"""

import argparse
import time

import jax
import numpy as np

import bayescal as bc
from bayescal.inference._priors import default_prior
from bayescal.inference._thermal_posterior import sample_thermal
from bayescal.models._thermal import ThermalRecord, thermal_problem

RATE, T0 = 10.0, 35.0
LAB = np.array([0.50, 0.0100, -2.0e-4])
NOW = np.array([0.51, 0.0108, -2.0e-4])
NOISE = {"N": 0.005, "K": 1e-4}
HELD_OUT = np.concatenate([np.linspace(20, 30, 21), np.linspace(36, 45, 19)])


def bias(coefficients, temperature):
    return ((temperature[:, None] - T0) ** np.arange(3)) @ coefficients


def scenario(seed):
    keys = jax.random.split(jax.random.PRNGKey(40_000 + seed), 8)
    model = bc.NoiseModel(rate_hz=RATE, **NOISE)
    n = 18_000
    lab_temperature = 45 - 25 * np.exp(-np.arange(n) / RATE / 500)
    lab = bias(LAB, lab_temperature) + np.asarray(model.sample(keys[0], n))
    rng = np.random.default_rng(seed)
    pieces, temperatures, periods, measured, start = [], [], [], [], 0
    for index, centre in enumerate(np.linspace(30, 36, 6)):
        m = 1200
        temperature = centre + 0.3 * np.sin(np.arange(m) / 150 + rng.uniform(0, 6))
        offset = rng.normal(0, 0.003)
        pieces.append(
            bias(NOW, temperature) + offset + np.asarray(model.sample(keys[1 + index], m))
        )
        temperatures.append(temperature)
        periods.append((start, start + m))
        measured.append((offset + rng.normal(0, 0.001), 0.001))
        start += m
    field = ThermalRecord(
        np.concatenate(pieces), np.concatenate(temperatures), RATE, tuple(periods)
    )
    return ThermalRecord(lab, lab_temperature, RATE, ((0, n),)), field, measured


def evaluate(mean, covariance):
    design = (HELD_OUT[:, None] - T0) ** np.arange(3)
    error = design @ mean - bias(NOW, HELD_OUT)
    sd = np.sqrt(np.einsum("ij,jk,ik->i", design, covariance, design))
    return float(np.sqrt(np.mean(error**2))), float(np.mean(np.abs(error) <= 1.645 * sd))


def run(seed):
    lab, field, measured = scenario(seed)
    terms = ("white", "rate_random_walk")
    old = bc.fit_thermal(
        lab.values, lab.temperature, RATE, degree=2, reference=T0, terms=terms, seed=seed
    )
    # The field data alone: its periods and their measured offsets, under a flat prior on the
    # coefficients (no public function fits several periods without a prior calibration).
    noise_prior = default_prior(terms, bc.allan_deviation(field.values, RATE))
    fresh = sample_thermal(
        thermal_problem(field, 2, T0, noise_prior=noise_prior, offset_prior=measured),
        2,
        T0,
        seed=seed,
    )
    updated, exact = (
        old.update(
            field.values,
            field.temperature,
            RATE,
            periods=field.periods,
            offsets=measured,
            drift=drift,
            seed=seed,
        )
        for drift in ("auto", None)
    )
    results = {
        "old lab calibration": evaluate(old.coefficients, old.covariance),
        "fresh fit of field data": evaluate(fresh.coefficient_mean, fresh.coefficient_covariance),
        "updated calibration": evaluate(updated.coefficients, updated.covariance),
        "updated, no drift allowed": evaluate(exact.coefficients, exact.covariance),
    }
    healthy = old.passed and fresh.diagnostics.passed and updated.passed and exact.passed
    return results, healthy, updated.drift["scale"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", type=int, default=20)
    args = parser.parse_args()
    start = time.perf_counter()
    table, unhealthy, drifts = {}, 0, []
    for seed in range(args.scenarios):
        results, healthy, drift = run(seed)
        unhealthy += not healthy
        drifts.append(drift)
        for name, values in results.items():
            table.setdefault(name, []).append(values)
    print(
        f"thermal update: {args.scenarios} scenarios, {time.perf_counter() - start:.0f} s; "
        f"{unhealthy} with a failed health check"
    )
    print(f"  {'calibration':<26}{'RMSE of bias, held-out T [deg/s]':>34}{'90 % band covers':>20}")
    for name, rows in table.items():
        scores = np.array(rows)
        print(f"  {name:<26}{scores[:, 0].mean():>34.5f}{scores[:, 1].mean():>20.3f}")
    half = max(T0 - 20.0, 45.0 - T0)
    print(
        f"  drift learned by the update: s = {np.mean(drifts):.4f} deg/s on average (range "
        f"{np.min(drifts):.4f}-{np.max(drifts):.4f}); the simulated aging moved c0 by "
        f"{NOW[0] - LAB[0]:.4f} and c1 h by {(NOW[1] - LAB[1]) * half:.4f} deg/s (h = {half:g})"
    )


if __name__ == "__main__":
    main()
