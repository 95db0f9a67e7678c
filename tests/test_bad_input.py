"""Bad input: each case exits with code 2 and one line that names the file, the column (or
argument), where the problem is, and what to do; and writes no output."""

import numpy as np
import pytest
from recording_files import write_csv


@pytest.fixture
def good_columns():
    rng = np.random.default_rng(3)
    n = 2000
    return {"time": np.arange(n) / 100.0, "gyro_x": 0.4 + 0.03 * rng.standard_normal(n)}


def assert_rejected(run_cli, tmp_path, args, *fragments):
    output = tmp_path / "out.json"
    code, stdout, stderr = run_cli("noise", *args, "--json", output)
    assert code == 2, stderr
    message = stderr.strip()
    assert "\n" not in message and "Traceback" not in message
    for fragment in fragments:
        assert fragment in message, message
    assert not output.exists()
    assert stdout == ""
    return message


def test_missing_file(run_cli, tmp_path):
    assert_rejected(
        run_cli,
        tmp_path,
        [tmp_path / "nope.csv", "--channel", "gyro_x"],
        "nope.csv",
        "no such file",
        "check the path",
    )


def test_unknown_format(run_cli, tmp_path):
    path = tmp_path / "pad.xlsx"
    path.write_text("x")
    assert_rejected(
        run_cli, tmp_path, [path, "--channel", "gyro_x"], "pad.xlsx", ".csv, .parquet or .npz"
    )


def test_missing_channel_lists_columns(run_cli, tmp_path, good_columns):
    path = write_csv(tmp_path / "pad.csv", good_columns)
    assert_rejected(
        run_cli,
        tmp_path,
        [path, "--channel", "gyro_q"],
        "pad.csv",
        "gyro_q",
        "columns are: time, gyro_x",
    )


def test_text_channel(run_cli, tmp_path, good_columns):
    path = tmp_path / "pad.csv"
    path.write_text("time,gyro_x,state\n0,1,a\n0.01,2,b\n")
    assert_rejected(
        run_cli, tmp_path, [path, "--channel", "state"], "pad.csv", "'state'", "not numeric"
    )


def test_nan_value_names_row_and_time(run_cli, tmp_path, good_columns):
    good_columns["gyro_x"][1042] = np.nan
    path = write_csv(tmp_path / "pad.csv", good_columns)
    assert_rejected(
        run_cli,
        tmp_path,
        [path, "--channel", "gyro_x"],
        "pad.csv",
        "'gyro_x'",
        "data row 1043",
        "t = 10.42 s",
        "--start/--stop",
    )


def test_empty_cell_is_missing_value(run_cli, tmp_path):
    path = tmp_path / "pad.csv"
    lines = ["time,gyro_x"] + [f"{k / 100},{'' if k == 500 else 0.1 * (k % 7)}" for k in range(600)]
    path.write_text("\n".join(lines) + "\n")
    assert_rejected(run_cli, tmp_path, [path, "--channel", "gyro_x"], "data row 501")


@pytest.mark.parametrize(
    ("index", "value", "word"), [(700, 6.99, "duplicated"), (700, 6.5, "decreasing")]
)
def test_time_stamps_must_increase(run_cli, tmp_path, good_columns, index, value, word):
    good_columns["time"][index] = value
    path = write_csv(tmp_path / "pad.csv", good_columns)
    assert_rejected(
        run_cli,
        tmp_path,
        [path, "--channel", "gyro_x"],
        "pad.csv",
        "'time'",
        word,
        f"data row {index + 1}",
        "de-duplicate",
    )


def test_gap_is_an_error_unless_split(run_cli, tmp_path, good_columns):
    good_columns["time"][1000:] += 5.0
    path = write_csv(tmp_path / "pad.csv", good_columns)
    assert_rejected(
        run_cli,
        tmp_path,
        [path, "--channel", "gyro_x"],
        "pad.csv",
        "gap of 5.01 s",
        "data row 1001",
        "--gaps split",
    )
    code, stdout, stderr = run_cli("noise", path, "--channel", "gyro_x", "--gaps", "split")
    assert code == 0, stderr
    assert "1 gap(s) split" in stdout and "500 missing sample(s)" in stdout


def test_irregular_sampling(run_cli, tmp_path, good_columns):
    rng = np.random.default_rng(1)
    good_columns["time"] = np.cumsum(rng.uniform(0.005, 0.015, good_columns["time"].size))
    path = write_csv(tmp_path / "pad.csv", good_columns)
    assert_rejected(
        run_cli,
        tmp_path,
        [path, "--channel", "gyro_x"],
        "pad.csv",
        "'time'",
        "irregular sampling",
        "--rate HZ",
    )


def test_too_few_samples(run_cli, tmp_path, good_columns):
    path = write_csv(tmp_path / "pad.csv", good_columns)
    assert_rejected(
        run_cli,
        tmp_path,
        [path, "--channel", "gyro_x", "--start", "3", "--stop", "3.05"],
        "pad.csv",
        "only 5 samples",
        "at least 16",
    )


def test_too_few_samples_for_requested_tau(run_cli, tmp_path, good_columns):
    path = write_csv(tmp_path / "pad.csv", good_columns)
    assert_rejected(
        run_cli,
        tmp_path,
        [path, "--channel", "gyro_x", "--taus", "1,100"],
        "pad.csv",
        "'gyro_x'",
        "100 s needs more samples",
        "longest averaging time here is 10 s",
    )


def test_constant_channel(run_cli, tmp_path, good_columns):
    good_columns["gyro_x"][:] = 0.25
    path = write_csv(tmp_path / "pad.csv", good_columns)
    assert_rejected(
        run_cli,
        tmp_path,
        [path, "--channel", "gyro_x"],
        "pad.csv",
        "'gyro_x'",
        "constant at 0.25",
        "sensor was recording",
    )


def test_stuck_at_rail(run_cli, tmp_path, good_columns):
    good_columns["gyro_x"][1500:1530] = 250.0
    path = write_csv(tmp_path / "pad.csv", good_columns)
    assert_rejected(
        run_cli,
        tmp_path,
        [path, "--channel", "gyro_x"],
        "pad.csv",
        "'gyro_x'",
        "stuck at a rail",
        "30 consecutive samples at 250",
        "data row 1501",
        "--start/--stop",
    )


def test_no_time_and_no_rate(run_cli, tmp_path, good_columns):
    del good_columns["time"]
    path = write_csv(tmp_path / "pad.csv", good_columns)
    assert_rejected(
        run_cli, tmp_path, [path, "--channel", "gyro_x"], "pad.csv", "no time column", "--rate HZ"
    )


def test_time_in_milliseconds_needs_its_unit(run_cli, tmp_path, good_columns):
    good_columns["timestamp"] = good_columns.pop("time") * 1000
    path = write_csv(tmp_path / "pad.csv", good_columns)
    assert_rejected(
        run_cli,
        tmp_path,
        [path, "--channel", "gyro_x"],
        "pad.csv",
        "'timestamp'",
        "sample rate of 0.1 Hz",
        "--time-unit",
    )
    code, stdout, _ = run_cli("noise", path, "--channel", "gyro_x", "--time-unit", "ms")
    assert code == 0 and "at 100 Hz" in stdout


def test_json_folder_must_exist(run_cli, tmp_path, good_columns):
    path = write_csv(tmp_path / "pad.csv", good_columns)
    code, stdout, stderr = run_cli(
        "noise", path, "--channel", "gyro_x", "--json", tmp_path / "missing" / "out.json"
    )
    assert code == 2 and "--json" in stderr and "does not exist" in stderr and stdout == ""


def test_pad_without_liftoff(run_cli, tmp_path, good_columns):
    rng = np.random.default_rng(2)
    n = good_columns["time"].size
    good_columns.update(
        {
            "acc_x": 0.01 * rng.standard_normal(n),
            "acc_y": 0.01 * rng.standard_normal(n),
            "acc_z": 1 + 0.01 * rng.standard_normal(n),
        }
    )
    path = write_csv(tmp_path / "pad.csv", good_columns)
    assert_rejected(
        run_cli,
        tmp_path,
        [path, "--channel", "gyro_x", "--pad"],
        "pad.csv",
        "no liftoff found",
        "--start/--stop",
    )


def test_usage_errors_exit_2(run_cli):
    code, _, stderr = run_cli("noise", "--example", "--confidence", "95")
    assert code == 2 and "between 0 and 1" in stderr
    code, _, stderr = run_cli("noise")
    assert code == 2 and "no recording given" in stderr
