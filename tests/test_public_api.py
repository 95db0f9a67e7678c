"""The public API, used as a person would from a notebook, on simulations with known truth:
the noise model's simulator, spectrum and likelihood share their parameters; a noise fit
recovers N and K; discovery names a hidden thermal bias; a thermal
calibration's compensated output is flat in temperature. Public names only."""

import jax
import numpy as np
import pytest

import bayescal as bc

RATE = 100.0


def test_the_model_spectrum_is_what_simulated_periodograms_average_to():
    """Stationary terms (white noise through the output filter, quantization): the mean
    periodogram of simulated records against ``psd``, within 4 standard errors at every
    frequency tested; white noise reads N^2."""
    model = bc.NoiseModel(rate_hz=RATE, N=0.01, Q=5e-5, F=0.3)
    n, replicas = 4096, 512
    keys = jax.random.split(jax.random.PRNGKey(11), replicas)
    samples = np.asarray(jax.jit(jax.vmap(lambda key: model.sample(key, n)))(keys))
    periodogram = np.abs(np.fft.rfft(samples - samples.mean(axis=1, keepdims=True))) ** 2
    periodogram /= n * RATE
    index = np.array([40, 200, 800, 1600, 2000])
    frequency = index * RATE / n
    mean = periodogram[:, index].mean(axis=0)
    error = periodogram[:, index].std(axis=0) / np.sqrt(replicas)
    assert np.all(np.abs(mean - np.asarray(model.psd(frequency))) < 4 * error)
    white = bc.NoiseModel(rate_hz=RATE, N=0.01)
    np.testing.assert_allclose(np.asarray(white.psd(frequency)), 0.01**2, rtol=1e-12)


def test_the_likelihood_peaks_at_the_parameters_that_simulated_the_record():
    truth = {"bias": 0.4, "N": 0.004, "K": 2e-4}
    y = bc.NoiseModel(rate_hz=RATE, **truth).simulate(2**16, seed=4)
    at_truth = bc.NoiseModel(rate_hz=RATE, **truth).log_likelihood(y)
    for changed in ({"N": 0.0044}, {"N": 0.0036}, {"K": 6e-4}, {"bias": 0.5}):
        other = bc.NoiseModel(rate_hz=RATE, **{**truth, **changed})
        assert other.log_likelihood(y) < at_truth, changed


def test_a_noise_fit_recovers_white_noise_and_random_walk():
    """One record: the truth within 3 posterior sd of the mean (a correct posterior fails this
    0.3 % of the time; that its 90 % intervals cover at their rate is
    tests/test_noise_fit.py's coverage study, and benchmarks/noise_coverage.py's)."""
    truth = {"N": 0.0035, "K": 4e-5}
    y = bc.NoiseModel(rate_hz=RATE, bias=0.4, **truth).simulate(2**18, seed=0)
    fit = bc.fit_noise(y, RATE, terms="white,rate_random_walk", unit="deg/s", seed=0)
    fit.check()
    for name, value in truth.items():
        summary = fit.summary[name]
        assert abs(summary["mean"] - value) < 3 * summary["sd"], (name, summary)
    assert fit.summary["K"]["unit"] == "deg/s*sqrt(Hz)"
    posterior = fit.posterior["posterior"]
    assert set(posterior.data_vars) == {"bias", "N", "K"}
    assert posterior["N"].attrs["units"] == "deg/s/sqrt(Hz)"


def warm_up(n=2**15, rate=20.0, slope=0.002, seed=2):
    t = np.arange(n) / rate
    temperature = 25 + 12 * (1 - np.exp(-t / 300)) + 0.5 * np.sin(2 * np.pi * t / 400)
    noise = bc.NoiseModel(rate_hz=rate, N=0.005, B=5e-4).simulate(n, seed=seed)
    return 0.1 + slope * (temperature - 30) + noise, temperature, rate


def test_discovery_names_a_hidden_thermal_bias():
    y, temperature, rate = warm_up()
    found = bc.discover(y, rate, temperature=temperature, unit="deg/s", channel="gyro_z")
    assert [effect.name for effect in found.effects] == ["thermal_bias"]
    slope = found.effects[0].parameters["c1"]
    assert slope["q05"] <= 0.002 <= slope["q95"] and slope["unit"] == "deg/s/degC"
    assert found.check().passed


def test_a_thermal_calibration_leaves_an_output_flat_in_temperature(tmp_path):
    y, temperature, rate = warm_up(seed=3)
    calibration = bc.fit_thermal(y, temperature, rate, degree="auto", seed=0).check()
    compensated, sd = calibration.compensate(y, temperature)
    slope = np.polyfit(temperature, compensated, 1)[0]
    raw_slope = np.polyfit(temperature, y, 1)[0]
    assert abs(slope) < 0.05 * abs(raw_slope)
    # The calibration's c0 is the whole bias at T0: what is left is the noise, about zero.
    assert np.all(sd > 0) and abs(np.mean(compensated)) < 0.002
    saved = calibration.save(tmp_path / "cal.json")
    again = bc.load_thermal_calibration(saved, unit="deg/s")
    np.testing.assert_allclose(again.bias(temperature)[0], calibration.bias(temperature)[0])
    with pytest.raises(bc.InputError, match="rad/s"):
        bc.load_thermal_calibration(saved, unit="rad/s")


def test_jax_runs_in_64_bit_mode_and_says_so():
    """Using bayescal turns on JAX's 64-bit mode for the process (documented in Getting
    started); with it turned off its computations refuse to run rather than compute in
    float32, and an environment asking for float32 is overridden with a warning."""
    import os
    import subprocess
    import sys

    assert bc.NoiseModel(rate_hz=RATE, N=0.01).simulate(8, seed=1).dtype == np.float64
    assert jax.config.jax_enable_x64
    y = bc.NoiseModel(rate_hz=RATE, N=0.01).simulate(4096, seed=2)
    with jax.enable_x64(False):
        with pytest.raises(bc.InputError, match="64-bit mode is off"):
            bc.NoiseModel(rate_hz=RATE, N=0.01).simulate(8, seed=1)
        with pytest.raises(bc.InputError, match=r"with jax\.enable_x64\(False\)"):
            bc.fit_noise(y, RATE, terms=("white",))
    environment = {**os.environ, "JAX_ENABLE_X64": "0", "JAX_PLATFORMS": "cpu"}
    done = subprocess.run(
        [sys.executable, "-W", "error::UserWarning", "-c",
         "import bayescal as bc; bc.NoiseModel(rate_hz=100.0, N=0.01)"],
        capture_output=True, text=True, env=environment, check=False,
    )  # fmt: skip
    assert done.returncode != 0 and "JAX_ENABLE_X64=0 is overridden" in done.stderr
    done = subprocess.run(
        [sys.executable, "-c",
         "import bayescal as bc; print(bc.NoiseModel(rate_hz=100.0, N=0.01).simulate(4).dtype)"],
        capture_output=True, text=True, env=environment, check=False,
    )  # fmt: skip
    assert done.stdout.strip() == "float64", done.stderr
