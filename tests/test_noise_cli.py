"""``bayescal noise``: the JSON contract, the file formats, and real recordings checked
against independent computations."""

import contextlib
import io
import json

import numpy as np
import pytest
from scipy import stats

allantools = pytest.importorskip("allantools")


@pytest.fixture(scope="module")
def example(tmp_path_factory):
    """``bayescal noise --example --json``, run once (a posterior of 360,000 samples) for the
    tests that read it: its exit code, its printed text and its JSON document."""
    from bayescal.cli import main

    output = tmp_path_factory.mktemp("example") / "out.json"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        try:
            code = main(["noise", "--example", "--json", str(output)])
        except SystemExit as exit_:
            code = exit_.code
    return code, printed.getvalue(), json.loads(output.read_text())


def test_example_json_contract(example):
    code, stdout, result = example
    assert code == 0
    assert result["bayesian"]["diagnostics"]["passed"]
    assert result["channel"] == "gyro_x" and result["unit"] == "deg/s"
    assert result["n_samples"] == 360000 and result["rate_hz"] == 100.0
    assert result["duration_s"] == pytest.approx(3600.0)
    assert result["window"]["start_s"] == 0.0 and result["window"]["stop_s"] == pytest.approx(
        3600.0
    )
    classical = result["classical"]
    bias = classical["bias"]
    assert bias["ci_low"] < bias["value"] < bias["ci_high"]
    assert bias["confidence"] == 0.95 and bias["unit"] == "deg/s"
    assert classical["std"]["unit"] == "deg/s"
    assert isinstance(classical["t_interval_valid"], bool)
    allan = classical["allan"]
    assert allan["unit"] == "deg/s"
    assert (
        len(allan["tau_s"]) == len(allan["adev"]) == len(allan["ci_low"]) == len(allan["ci_high"])
    )
    assert all(
        lo < dev < hi
        for lo, dev, hi in zip(allan["ci_low"], allan["adev"], allan["ci_high"], strict=True)
    )
    units = {name: reading["unit"] for name, reading in classical["slope_readings"].items()}
    assert units == {"N": "deg/s/sqrt(Hz)", "B": "deg/s", "K": "deg/s*sqrt(Hz)", "Q": "deg"}
    assert "bias" in stdout and "IEEE 952" in stdout


def test_example_recovers_its_white_noise_and_flags_the_random_walk(example):
    """The example gyro has N = 0.0035 deg/s/sqrt(Hz) and a rate random walk that makes its
    Student-t interval too narrow."""
    classical = example[2]["classical"]
    reading = classical["slope_readings"]["N"]
    assert reading["kind"] == "reading" and reading["ci_low"] < 0.0035 < reading["ci_high"]
    assert classical["t_interval_valid"] is False and classical["t_interval_widening"] > 1.2


def test_white_noise_keeps_a_valid_t_interval(run_cli, tmp_path):
    rng = np.random.default_rng(11)
    n = 50_000
    path = tmp_path / "white.csv"
    path.write_text(
        "time,gyro_x[deg/s]\n"
        + "\n".join(
            f"{k / 100:.2f},{value:.6f}"
            for k, value in enumerate(0.2 + 0.05 * rng.standard_normal(n))
        )
    )
    output = tmp_path / "out.json"
    code, _, stderr = run_cli(
        "noise", path, "--channel", "gyro_x", "--classical-only", "--json", output
    )
    assert code == 0, stderr
    classical = json.loads(output.read_text())["classical"]
    assert classical["t_interval_valid"] is True and classical["t_interval_widening"] == 1.0
    assert json.loads(output.read_text())["notes"] == []


@pytest.mark.parametrize("suffix", [".parquet", ".npz"])
def test_formats_read_alike(run_cli, tmp_path, suffix):
    rng = np.random.default_rng(5)
    columns = {"time": np.arange(4000) / 50.0, "gyro_z[rad/s]": 0.01 * rng.standard_normal(4000)}
    csv = tmp_path / "rec.csv"
    csv.write_text(
        "time,gyro_z[rad/s]\n"
        + "\n".join(
            f"{t!r},{v!r}"
            for t, v in zip(
                columns["time"].tolist(), columns["gyro_z[rad/s]"].tolist(), strict=True
            )
        )
    )
    other = tmp_path / f"rec{suffix}"
    if suffix == ".npz":
        np.savez(other, **columns)
    else:
        import pyarrow as pa
        import pyarrow.parquet as pq

        pq.write_table(pa.table(columns), other)
    # What is read is the subject: the classical results are a function of the samples alone
    # (the posterior is the same function of the same samples, and is tested elsewhere).
    results = []
    for path in (csv, other):
        output = tmp_path / f"{path.suffix}.json"
        code, _, stderr = run_cli(
            "noise", path, "--channel", "gyro_z", "--classical-only", "--json", output
        )
        assert code == 0, stderr
        results.append(json.loads(output.read_text()))
    assert results[0]["unit"] == results[1]["unit"] == "rad/s"
    assert results[0]["classical"] == results[1]["classical"]


def test_rocket_pad_against_flight_computer_state(run_cli, tmp_path, shared_data):
    """ISSUIUC TARS flight log: the pad window bayescal finds from the accelerometer is the
    flight computer's own pad state (rocket_state == 1), and the numbers agree with NumPy,
    SciPy and allantools on those rows."""
    path = shared_data / "issuiuc_rocket_flights/20211030/flight_computer_trimmed.csv"
    output = tmp_path / "pad.json"
    code, _, stderr = run_cli(
        "noise",
        path,
        "--channel",
        "gx",
        "--unit",
        "deg/s",
        "--time-unit",
        "ms",
        "--pad",
        "--classical-only",  # the window and the classical numbers are the subject
        "--json",
        output,
    )
    assert code == 0, stderr
    result = json.loads(output.read_text())

    import pyarrow.csv as pa_csv

    table = pa_csv.read_csv(path)
    on_pad = table["rocket_state"].to_numpy() == 1
    assert on_pad[:583].all() and not on_pad[583:].any()
    gyro = table["gx"].to_numpy()[on_pad]
    assert result["n_samples"] == gyro.size
    assert result["window"]["selected_by"] == "pad"
    assert result["window"]["liftoff_s"] == pytest.approx(5.83, abs=0.02)

    classical = result["classical"]
    low, high = stats.t.interval(0.95, gyro.size - 1, loc=gyro.mean(), scale=stats.sem(gyro))
    assert classical["bias"]["value"] == pytest.approx(gyro.mean(), rel=1e-12)
    assert classical["bias"]["ci_low"] == pytest.approx(low, rel=1e-12)
    assert classical["bias"]["ci_high"] == pytest.approx(high, rel=1e-12)
    assert classical["std"]["value"] == pytest.approx(gyro.std(ddof=1), rel=1e-12)
    taus = np.asarray(classical["allan"]["tau_s"])
    _, expected, _, _ = allantools.oadev(gyro, rate=100.0, data_type="freq", taus=taus)
    np.testing.assert_allclose(classical["allan"]["adev"], expected, rtol=1e-9)


def test_psas_launch_pad(run_cli, tmp_path, shared_data):
    """PSAS Launch-12 telemetry: liftoff at 4.49 s (acc_x > 2 g, SOURCE.txt), ADIS16405 at
    about 816 Hz with dropped packets after liftoff."""
    path = shared_data / "psas_adis16405/Launch-12/telemetry_ADIS_decoded.csv"
    output = tmp_path / "pad.json"
    code, _, stderr = run_cli(
        "noise", path, "--channel", "gyro_z_dps", "--pad", "--classical-only", "--json", output
    )
    assert code == 0, stderr
    result = json.loads(output.read_text())
    assert 4.4 < result["window"]["liftoff_s"] < 4.5
    assert result["window"]["stop_s"] <= result["window"]["liftoff_s"] + 2 / result["rate_hz"]
    assert result["rate_hz"] == pytest.approx(816, rel=0.01)
    assert result["n_samples"] == pytest.approx(3657, abs=10)


def test_psas_pad_names_the_adis16405_bartlett_filter(run_cli, tmp_path, shared_data):
    """The ADIS16405's output is its default Bartlett FIR (two cascaded 4-tap averages,
    datasheet SENS_AVG): chosen by evidence among the filter shapes and measured as 4 taps.
    What the sinc^2 shape leaves in its null (about 1.25x the model's power near 204 Hz, from
    the internal sampling) is reported as a misfit, never a healthy posterior."""
    path = shared_data / "psas_adis16405/Launch-12/telemetry_ADIS_decoded.csv"
    output = tmp_path / "pad.json"
    code, _, stderr = run_cli(
        "noise", path, "--channel", "gyro_z_dps", "--pad", "--seed", "1", "--json", output
    )
    bayesian = json.loads(output.read_text())["bayesian"]
    assert "decimation_filter" in bayesian["terms"]
    length = bayesian["parameters"]["filter_length"]
    assert 3.9 < length["q05"] < 4.0 < length["q95"] < 4.1
    if code == 1:
        assert "model misfit: the power in the band" in stderr
        assert bayesian["diagnostics"]["passed"]
    else:
        assert code == 0, stderr
