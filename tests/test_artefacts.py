"""What loggers write besides readings, read right or refused with advice: placeholder rows
(0 in every sensor column while the rows beside them are not), a metadata line that states
the rate or the unit, a units row under the header; and the Student-t sentence, which says
what the interval of its ratio does on either side of 1."""

import numpy as np
import pytest
from recording_files import write_csv

import bayescal as bc
from bayescal.classical._noise import TIntervalCheck
from bayescal.report._noise import t_interval_explanation

RATE = 100.0
SAMPLES = 2000


def _imu(seed: int = 0) -> dict:
    rng = np.random.default_rng(seed)
    return {
        "time": np.arange(SAMPLES) / RATE,
        "gyro_x": 0.4 + 0.05 * rng.standard_normal(SAMPLES),
        "acc_x": -1.01 + 0.004 * rng.standard_normal(SAMPLES),
        "qw": np.ones(SAMPLES),  # orientation, never 0
    }


def test_a_placeholder_first_row_in_the_sensor_columns_is_left_out(tmp_path):
    """The logger's first row holds 0 in the sensor columns but not in time or orientation:
    left out with a note, so the bias is the record's (it was a 250-sd sample)."""
    columns = _imu()
    clean = bc.load_recording(write_csv(tmp_path / "clean.csv", columns)).channel("acc_x")
    columns["gyro_x"][0] = columns["acc_x"][0] = 0.0
    recording = bc.load_recording(write_csv(tmp_path / "zeros.csv", columns))
    channel = recording.channel("acc_x")
    assert any(
        "data row 1 holds 0 in every sensor column (gyro_x, acc_x)" in n for n in channel.notes
    )
    np.testing.assert_array_equal(channel.values, clean.values[1:])
    assert recording.row_offset == 1


def test_placeholder_rows_further_on_are_missing_samples_in_their_place(tmp_path):
    """Rows 501 and 1201 placeholders: with a time column or an even rate alike, their
    samples are missing (NaN) in their place on the grid, and the rest is unchanged."""
    columns = _imu()
    for row in (500, 1200):
        columns["gyro_x"][row] = columns["acc_x"][row] = 0.0
    path = write_csv(tmp_path / "holes.csv", columns)
    for options in ({}, {"rate_hz": RATE}):
        channel = bc.load_recording(path).channel("acc_x", **options)
        assert channel.values.size == SAMPLES
        assert np.flatnonzero(np.isnan(channel.values)).tolist() == [500, 1200]
        assert any(
            "data rows 501 and 1201 hold 0 in every sensor column" in n for n in channel.notes
        )
    # A gyro whose readings sit on 0 is no placeholder: 0 is not far from its record.
    quiet = {
        "time": np.arange(SAMPLES) / RATE,
        "gyro_x": np.round(0.8 * np.random.default_rng(1).standard_normal(SAMPLES)),
    }
    channel = bc.load_recording(write_csv(tmp_path / "quiet.csv", quiet)).channel("gyro_x")
    assert not np.isnan(channel.values).any()


def test_a_metadata_line_states_the_rate_and_the_unit(tmp_path):
    columns = _imu()
    body = write_csv(tmp_path / "body.csv", {k: columns[k] for k in ("gyro_x", "acc_x")})
    path = tmp_path / "logger.csv"
    path.write_text("Fs,100\n" + body.read_text())
    channel = bc.load_recording(path).channel("gyro_x")
    assert channel.rate_hz == RATE
    assert any(
        "sample rate 100 Hz from the file's metadata (line 1, 'Fs,100')" in n for n in channel.notes
    )
    # Lines skipped with skip_rows are read too: a rate and a unit.
    path.write_text("Logger v2\nSample rate (Hz): 200\nUnits: g\n" + body.read_text())
    channel = bc.load_recording(path, skip_rows=3).channel("acc_x")
    assert channel.rate_hz == 200.0 and channel.unit == "g"
    # A unit for the accelerometers is not a gyro's.
    assert bc.load_recording(path, skip_rows=3).channel("gyro_x").unit == "deg/s"
    # Beside a time column, a rate that disagrees is said, and the stamps win.
    path.write_text("rate,50\n" + write_csv(tmp_path / "timed.csv", columns).read_text())
    channel = bc.load_recording(path).channel("gyro_x")
    assert channel.rate_hz == RATE
    assert any("metadata states 50 Hz" in n for n in channel.notes)


def test_a_units_row_under_the_header(tmp_path):
    columns = _imu()
    body = write_csv(tmp_path / "body.csv", columns).read_text().splitlines()
    path = tmp_path / "units.csv"
    path.write_text("\n".join([body[0], "s,deg/s,g,", *body[1:]]) + "\n")
    recording = bc.load_recording(path)
    assert recording.channel("acc_x").unit == "g"
    assert recording.channel("gyro_x").unit == "deg/s"
    assert recording.n_rows == SAMPLES


@pytest.mark.parametrize(
    "low, high, says",
    [(0.8, 1.3, "includes 1"), (0.26, 0.55, "lies below 1"), (1.2, 1.9, "correlated")],
)
def test_the_student_t_sentence_says_where_its_interval_lies(low, high, says):
    """'includes 1' only where it does (issue 34 found it printed for 0.26-0.55)."""
    valid = not low > 1.0
    check = TIntervalCheck(valid, 1.0 if valid else high, (low + high) / 2, low, high, 0.32)

    class Classical:
        t_interval = check

    sentence = t_interval_explanation(Classical())
    assert says in sentence
    if says != "includes 1":
        assert "includes 1" not in sentence


def test_report_takes_a_unit_per_channel(run_cli, tmp_path):
    """``report --units gyro_x=deg/s,acc_x=g``: each channel in its own unit (one --unit
    labelled accelerometers in g as m/s^2); a channel --units names that is not reported is
    refused, exit 2."""
    import json

    columns = _imu()
    path = write_csv(tmp_path / "imu.csv", {k: columns[k] for k in ("time", "gyro_x", "acc_x")})
    out = tmp_path / "out"
    code, _, stderr = run_cli(
        "report", path, "--channels", "gyro_x,acc_x", "--units", "gyro_x=deg/s,acc_x=g",
        "--terms", "white", "--out", out, "--quiet",
    )  # fmt: skip
    assert code == 0, stderr
    document = json.loads((out / "imu_report.json").read_text())
    units = {name: channel["unit"] for name, channel in document["channels"].items()}
    assert units == {"gyro_x": "deg/s", "acc_x": "g"}
    code, _, stderr = run_cli(
        "report", path, "--channels", "gyro_x", "--units", "acc_y=g", "--out", tmp_path / "x"
    )
    assert code == 2 and "--units names acc_y" in stderr
    code, _, stderr = run_cli("report", path, "--units", "acc_x:g", "--out", tmp_path / "y")
    assert code == 2 and "CHANNEL=UNIT" in stderr
