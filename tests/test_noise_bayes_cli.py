"""``bayescal noise`` with the Bayesian block: JSON contract, side-by-side table, ArviZ
netCDF output, sensor-card priors and the exit code of a failed health check."""

import json

import numpy as np
import pytest
import xarray as xr


@pytest.fixture(scope="module")
def white_and_walk(tmp_path_factory):
    rng = np.random.default_rng(21)
    n = 2**13
    walk = np.cumsum(rng.standard_normal(n)) * 1e-3 * np.sqrt(0.1)
    values = 0.25 + 0.02 * np.sqrt(10.0) * rng.standard_normal(n) + walk
    path = tmp_path_factory.mktemp("rec") / "gyro.csv"
    path.write_text(
        "time,gyro_z[deg/s]\n"
        + "\n".join(f"{k / 10:.1f},{value!r}" for k, value in enumerate(values.tolist()))
    )
    return path


def test_bayesian_block_contract(run_cli, tmp_path, white_and_walk):
    output, folder = tmp_path / "out.json", tmp_path / "posterior"
    code, stdout, stderr = run_cli(
        "noise",
        white_and_walk,
        "--channel",
        "gyro_z",
        "--json",
        output,
        "--out",
        folder,
        "--terms",
        "white,rrw",
        "--seed",
        "3",
    )
    assert code == 0, stderr
    result = json.loads(output.read_text())
    bayesian = result["bayesian"]
    assert bayesian["terms"] == ["white", "rate_random_walk"]
    assert set(bayesian["parameters"]) == {"bias", "N", "K"}
    units = {name: entry["unit"] for name, entry in bayesian["parameters"].items()}
    assert units == {"bias": "deg/s", "N": "deg/s/sqrt(Hz)", "K": "deg/s*sqrt(Hz)"}
    for entry in bayesian["parameters"].values():
        assert {"mean", "sd", "q05", "q95", "map", "map_sd", "unit"} <= set(entry)
        assert (
            entry["q05"] < entry["mean"] < entry["q95"] and entry["sd"] > 0 and entry["map_sd"] > 0
        )
    n_entry = bayesian["parameters"]["N"]
    assert n_entry["q05"] < 0.02 < n_entry["q95"]
    assert n_entry["display"]["deg/sqrt(h)"]["mean"] == pytest.approx(60 * n_entry["mean"])
    diagnostics = bayesian["diagnostics"]
    assert diagnostics["passed"] is True and diagnostics["failures"] == []
    assert set(diagnostics["rhat"]) == {"N", "K"} and min(diagnostics["ess_bulk"].values()) >= 400
    assert "classical" in result and "Bayesian" in stdout and "posterior checks passed" in stdout

    tree = xr.open_datatree(folder / "noise_gyro_z_posterior.nc", engine="h5netcdf")
    assert {"posterior", "sample_stats", "log_likelihood", "observed_data"} <= set(tree.children)
    assert tree["posterior"]["N"].attrs["units"] == "deg/s/sqrt(Hz)"
    assert float(tree["posterior"]["N"].mean()) == pytest.approx(n_entry["mean"], rel=1e-9)
    assert (
        json.loads((folder / "noise_gyro_z.json").read_text())["bayesian"]["terms"]
        == bayesian["terms"]
    )


def test_sensor_card_prior(run_cli, tmp_path, white_and_walk):
    output = tmp_path / "out.json"
    code, _, stderr = run_cli(
        "noise",
        white_and_walk,
        "--channel",
        "gyro_z",
        "--json",
        output,
        "--sensor",
        "mpu-6050",
        "--terms",
        "white,rrw",
    )
    assert code == 0, stderr
    prior = json.loads(output.read_text())["bayesian"]["prior"]
    assert prior.startswith("sensor card MPU-6050") and "PS-MPU-6000A-00" in prior


def test_unknown_sensor_and_term_exit_2(run_cli, white_and_walk):
    code, _, stderr = run_cli("noise", white_and_walk, "--channel", "gyro_z", "--sensor", "nope")
    assert code == 2 and "no such sensor card" in stderr and "MPU-6050" in stderr
    code, _, stderr = run_cli(
        "noise", white_and_walk, "--channel", "gyro_z", "--terms", "white,wobble"
    )
    assert code == 2 and "unknown term 'wobble'" in stderr


def test_failed_health_check_exits_1_and_says_which(run_cli, tmp_path, white_and_walk):
    output = tmp_path / "out.json"
    # The record's own terms: the term search is tested on it elsewhere.
    code, stdout, stderr = run_cli(
        "noise", white_and_walk, "--channel", "gyro_z", "--terms", "white,rrw",
        "--json", output, "--max-steps", "250",
    )  # fmt: skip
    assert code == 1
    assert "HEALTH CHECK FAILED" in stderr and "autocorrelation-time criterion" in stderr
    assert "POSTERIOR CHECKS FAILED" in stdout
    assert json.loads(output.read_text())["bayesian"]["diagnostics"]["passed"] is False


def test_profile_prints_each_stage_on_stderr(run_cli, white_and_walk):
    code, stdout, stderr = run_cli(
        "noise", white_and_walk, "--channel", "gyro_z", "--terms", "white,rrw",
        "--max-steps", "250", "--profile",
    )  # fmt: skip
    profile = stderr[stderr.index("profile (s):") :].splitlines()
    stages = [line.split(maxsplit=1) for line in profile[1:]]
    names = [name for _, name in stages]
    assert names[0] == "reading the recording" and names[-1] == "total", names
    assert "posterior (MAP, emcee, draws)" in names and "writing the outputs" in names
    assert "classical (bias, Allan deviation with intervals, readings)" in names
    seconds = {name: float(value) for value, name in stages}
    inner = (
        "reading the recording",
        "writing the outputs",
        "other (imports, JAX's start-up, the text)",
    )
    assert sum(seconds[n] for n in inner) <= seconds["total"] + 0.02
    assert "profile" not in stdout and code == 1  # 250 steps: the checks fail, as above


def test_sensors_lists_the_cards(run_cli):
    code, stdout, _ = run_cli("sensors")
    assert code == 0
    for name in ("ADIS16405", "MPU-6050", "BMI088", "ICM-42688-P", "LSM6DSO", "ADIS16495-1"):
        assert name in stdout
