"""Hostile input, generated: every command over malformed recordings, arguments and
calibration files ends in exit 0 (with the right answer where the change cannot alter it),
1 (a health check) or 2 (one line that says what is wrong, and no file left behind) — never
in exit 3, never with a traceback, and no numpy warning on the terminal before the message
(a RuntimeWarning is an error here: pytest would otherwise capture what a user sees).

Hypothesis draws the cases, derandomized (the same cases on every run) and bounded (unless a
longer sweep is asked for, :data:`SWEEP`), on
recordings short enough that no command reaches its sampler: a recording under 33 rows is
refused by every Bayesian path, so the generated cases test reading and checking, fast.
"""

import contextlib
import json
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")

SWEEP = int(os.environ.get("BAYESCAL_FUZZ_SWEEP", "0"))
"""0 in the suite (derandomized, bounded); N > 0 a longer sweep: N times the cases, drawn at
random (``BAYESCAL_FUZZ_SWEEP=10 python -m pytest tests/test_fuzz.py``)."""
FUZZ = settings(
    derandomize=not SWEEP,
    database=None,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
RATE = 100.0
HEADER = ["time", "gyro_x[deg/s]", "acc_x", "acc_y", "acc_z", "temperature"]


def _rows(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack(
        [
            np.arange(n) / RATE,
            0.4 + 0.03 * rng.standard_normal(n),
            0.01 * rng.standard_normal(n),
            0.01 * rng.standard_normal(n),
            9.8 + 0.01 * rng.standard_normal(n),
            np.linspace(20.0, 30.0, n),
        ]
    )


def _csv_text(rows: np.ndarray, header=HEADER, delimiter=",") -> str:
    lines = [delimiter.join(header)]
    lines += [delimiter.join(f"{value:.10g}" for value in row) for row in rows]
    return "\n".join(lines) + "\n"


GOOD = _csv_text(_rows(300))
SHORT = _csv_text(_rows(24))  # under the 33 samples of the Bayesian model

HOSTILE_CELLS = [
    "",
    "NaN",
    "inf",
    "-inf",
    "ERR",
    "1e308",
    "-1e300",
    "1e-320",
    "0",
    "1,5",
    '"7"',
    "°",
    "0x1F",
    "1.2.3",
    "x" * 300,
    "2024-05-01T12:00:00",
    "12:00:00.5",
]


@st.composite
def mutated_text(draw, base: str = GOOD):
    """A CSV recording with one to three hostile changes, as bytes."""
    lines = base.splitlines()
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(
            st.sampled_from(
                [
                    "cell",
                    "drop_line",
                    "duplicate_line",
                    "swap_lines",
                    "header",
                    "preamble",
                    "truncate",
                    "column_count",
                    "empty",
                    "time",
                ]
            )
        )
        row = draw(st.integers(1, max(1, len(lines) - 1)))
        if kind == "cell" and len(lines) > 1:
            cells = lines[row].split(",")
            cells[draw(st.integers(0, len(cells) - 1))] = draw(st.sampled_from(HOSTILE_CELLS))
            lines[row] = ",".join(cells)
        elif kind == "drop_line" and len(lines) > 1:
            del lines[row]
        elif kind == "duplicate_line" and len(lines) > 1:
            lines.insert(row, lines[row])
        elif kind == "swap_lines" and len(lines) > 2:
            other = draw(st.integers(1, len(lines) - 1))
            lines[row], lines[other] = lines[other], lines[row]
        elif kind == "header":
            names = lines[0].split(",")
            position = draw(st.integers(0, len(names) - 1))
            names[position] = draw(
                st.sampled_from(
                    ["gyro_x", "time", "", "gyro/x", "temp[furlong]", "t[ms]", "acc_x[deg/s]", "°C"]
                )
            )
            lines[0] = ",".join(names)
        elif kind == "preamble":
            lines.insert(0, draw(st.sampled_from(["Logger v1.2", "# serial 7", "a,b", ""])))
        elif kind == "truncate":
            text = "\n".join(lines)
            lines = text[: draw(st.integers(0, len(text)))].splitlines() or [""]
        elif kind == "column_count" and len(lines) > 1:
            lines[row] += draw(st.sampled_from([",", ",1", ",,", ""]))
        elif kind == "empty":
            lines = lines[:1]
        elif kind == "time" and len(lines) > 1:
            factor = draw(st.sampled_from([1000.0, 1e-3, -1.0, 0.0, 1e9]))
            for index in range(1, len(lines)):
                cells = lines[index].split(",")
                with contextlib.suppress(ValueError):
                    cells[0] = f"{float(cells[0]) * factor:.10g}"
                lines[index] = ",".join(cells)
    data = ("\n".join(lines) + "\n").encode("utf-8")
    if draw(st.booleans()) and draw(st.booleans()):
        data = data.replace("°".encode(), b"\xb0")  # Latin-1
    if draw(st.integers(0, 9)) == 0:
        position = draw(st.integers(0, len(data)))
        data = data[:position] + draw(st.binary(min_size=1, max_size=8)) + data[position:]
    return data


def _check(code, stdout, stderr, out: Path, command):
    hypothesis.event(f"exit {code}")
    assert code in (0, 1, 2), (command, code, stderr)
    assert "Traceback" not in stderr and "internal error" not in stderr, (command, stderr)
    if code == 2:
        message = stderr.strip()
        assert message.startswith("bayescal") and "\n" not in message, (command, stderr)
        assert stdout == ""
        assert not any(out.iterdir()), (command, sorted(out.iterdir()))


def _workspace():
    folder = Path(tempfile.mkdtemp(prefix="bayescal-fuzz-"))
    (folder / "out").mkdir()
    return folder, folder / "out"


def _baseline(run_cli, folder: Path) -> dict:
    good = folder / "good.csv"
    good.write_text(GOOD)
    code, _, stderr = run_cli(
        "noise", good, "--channel", "gyro_x", "--classical-only", "--json", folder / "base.json"
    )
    assert code == 0, stderr
    return json.loads((folder / "base.json").read_text())


COMMANDS = {
    "noise": lambda rec, out: [
        "noise", rec, "--channel", "gyro_x", "--classical-only", "--json", out / "n.json"
    ],
    "two-position": lambda rec, out: [
        "two-position", rec, "--channel", "acc_z", "--latitude", "45", "--classical-only",
        "--json", out / "t.json",
    ],
    "multi-position": lambda rec, out: [
        "multi-position", rec, "--channels", "acc_x,acc_y,acc_z", "--latitude", "45",
        "--classical-only", "--json", out / "m.json",
    ],
    # Under the 256 samples discovery needs: refused after reading, before any fit.
    "discover": lambda rec, out: [
        "discover", rec, "--channel", "gyro_x", "--stop", "2", "--json", out / "d.json",
        "--quiet",
    ],
}  # fmt: skip


@settings(FUZZ, max_examples=120 * max(SWEEP, 1))
@given(data=mutated_text(), command=st.sampled_from(sorted(COMMANDS)))
def test_malformed_recordings(run_cli, data, command):
    folder, out = _workspace()
    recording = folder / "rec.csv"
    recording.write_bytes(data)
    argv = COMMANDS[command](recording, out)
    _check(*run_cli(*argv), out, argv)


@settings(FUZZ, max_examples=40 * max(SWEEP, 1))
@given(data=mutated_text(base=SHORT), command=st.sampled_from(["report", "thermal fit", "noise"]))
def test_malformed_short_recordings_on_the_bayesian_paths(run_cli, data, command):
    """No case here may reach a sampler: a short recording is refused before it."""
    folder, out = _workspace()
    recording = folder / "rec.csv"
    recording.write_bytes(data)
    argv = {
        "report": ["report", recording, "--out", out / "report"],
        "thermal fit": [
            "thermal",
            "fit",
            recording,
            "--channel",
            "gyro_x",
            "--json",
            out / "c.json",
        ],
        "noise": ["noise", recording, "--channel", "gyro_x", "--json", out / "n.json"],
    }[command]
    code, stdout, stderr = run_cli(*argv)
    assert code == 2, (argv, stderr)
    _check(code, stdout, stderr, out, argv)


NEUTRAL = ["semicolon", "tab", "crlf", "bom", "comments", "quotes", "reorder"]


@settings(FUZZ, max_examples=25 * max(SWEEP, 1))
@given(changes=st.lists(st.sampled_from(NEUTRAL), min_size=1, max_size=3, unique=True))
def test_layouts_that_cannot_change_the_answer(run_cli, changes):
    folder, out = _workspace()
    expected = _baseline(run_cli, folder)
    rows, header = _rows(300), list(HEADER)
    if "reorder" in changes:
        order = [5, 1, 0, 3, 2, 4]
        rows, header = rows[:, order], [header[i] for i in order]
    delimiter = ";" if "semicolon" in changes else "\t" if "tab" in changes else ","
    text = _csv_text(rows, header, delimiter)
    if "quotes" in changes:
        text = "\n".join(
            delimiter.join(f'"{cell}"' for cell in line.split(delimiter))
            for line in text.splitlines()
        )
    if "comments" in changes:
        text = "# exported by a logger\n# units: SI\n\n" + text
    if "crlf" in changes:
        text = text.replace("\n", "\r\n")
    data = text.encode()
    if "bom" in changes:
        data = b"\xef\xbb\xbf" + data
    recording = folder / "rec.csv"
    recording.write_bytes(data)
    code, _, stderr = run_cli(
        "noise", recording, "--channel", "gyro_x", "--classical-only", "--json", out / "n.json"
    )
    assert code == 0, (changes, stderr)
    found = json.loads((out / "n.json").read_text())
    for key in ("classical", "n_samples", "rate_hz", "unit"):
        assert found[key] == expected[key], (changes, key)


NUMBERS = ["0", "-1", "1", "0.5", "nan", "inf", "-inf", "1e-300", "1e300", "abc", "", "1/0", "3"]
OPTIONS = {
    "--rate": NUMBERS,
    "--start": NUMBERS,
    "--stop": NUMBERS,
    "--confidence": NUMBERS,
    "--taus": [*NUMBERS, ",", "1,2,-3", "octave", "1e-9,1e9"],
    "--unit": ["furlong", "deg/s", "m/s^2", "LSB", "", "g", "degC", "s"],
    "--time-unit": ["ms", "s", "furlong", "", "ns"],
    "--scale": [*NUMBERS, "MPU-6050", "nope", "1/131"],
    "--skip-rows": [*NUMBERS, "1000000"],
    "--names": ["a,b", "time,gyro_x", "a,,b", "t,gyro_x,acc_x,acc_y,acc_z,temperature"],
    "--gaps": ["split", "error", "maybe"],
    "--time-column": ["time", "gyro_x", "nope", "temperature"],
    "--samples-axis": ["0", "1", "-1"],
    "--seed": NUMBERS,
}


@settings(FUZZ, max_examples=80 * max(SWEEP, 1))
@given(
    options=st.dictionaries(
        st.sampled_from(sorted(OPTIONS)), st.integers(0, 20), min_size=1, max_size=4
    )
)
def test_hostile_arguments(run_cli, options):
    folder, out = _workspace()
    recording = folder / "rec.csv"
    recording.write_text(GOOD)
    argv = ["noise", recording, "--channel", "gyro_x", "--classical-only", "--json", out / "n.json"]
    for option, index in options.items():
        values = OPTIONS[option]
        argv += [option, values[index % len(values)]]
    _check(*run_cli(*argv), out, argv)


CALIBRATION = {
    "schema": "bayescal.thermal_calibration",
    "schema_version": 1,
    "channel": "gyro_x",
    "unit": "deg/s",
    "temperature_unit": "degC",
    "reference_temperature": 25.0,
    "degree": 1,
    "coefficients": [0.4, 0.001],
    "coefficient_units": ["deg/s", "deg/s/degC"],
    "covariance": [[1e-6, 0.0], [0.0, 1e-8]],
    "temperature_range": [20.0, 30.0],
    "noise": {"terms": ["white"], "N": {"mean": 0.003, "q05": 0.0028, "q95": 0.0032}},
    "earth_rate": None,
    "provenance": [{"step": "fit"}],
    "bayesian": {},
}
JSON_VALUES = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(10**6), 10**6)
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=8),
    lambda children: (
        st.lists(children, max_size=3) | st.dictionaries(st.text(max_size=5), children, max_size=3)
    ),
    max_leaves=6,
)


@st.composite
def calibration_files(draw):
    """A calibration file with a field removed or replaced, a number of an array field
    changed, dropped or added, a file of several channels whose map or entry is any JSON, or
    other JSON, or bytes."""
    kind = draw(
        st.sampled_from(["replace", "remove", "other", "bytes", "nested", "element", "several"])
    )
    if kind == "bytes":
        return draw(st.binary(max_size=64))
    if kind == "other":
        return json.dumps(draw(JSON_VALUES)).encode()
    document = json.loads(json.dumps(CALIBRATION))
    if kind == "several":
        entry = draw(st.sampled_from(["valid", "map", "entry"]))
        channels = (
            {"gyro_x": document}
            if entry == "valid"
            else draw(JSON_VALUES)
            if entry == "map"
            else {"gyro_x": draw(JSON_VALUES)}
        )
        several = {"schema": CALIBRATION["schema"], "schema_version": 1, "channels": channels}
        return json.dumps(several).encode()
    field = draw(st.sampled_from(sorted(CALIBRATION)))
    if kind == "remove":
        del document[field]
    elif kind == "replace":
        document[field] = draw(JSON_VALUES)
    elif kind == "element":  # one number of an array field changed, dropped or added
        name = draw(st.sampled_from(["coefficients", "covariance", "temperature_range"]))
        array = document[name]
        row = array[draw(st.integers(0, len(array) - 1))] if name == "covariance" else array
        action = draw(st.sampled_from(["change", "drop", "add"]))
        if action == "change":
            row[draw(st.integers(0, len(row) - 1))] = draw(JSON_VALUES)
        elif action == "drop":
            row.pop()
        else:
            row.append(draw(JSON_VALUES))
    else:
        document["noise"]["N"][draw(st.sampled_from(["mean", "q05", "q95"]))] = draw(JSON_VALUES)
    return json.dumps(document).encode()


@settings(FUZZ, max_examples=90 * max(SWEEP, 1))
@given(data=calibration_files(), step=st.sampled_from(["compensate", "update"]))
def test_malformed_calibration_files(run_cli, data, step):
    folder, out = _workspace()
    recording = folder / "rec.csv"
    recording.write_text(SHORT if step == "update" else GOOD)
    calibration = folder / "cal.json"
    calibration.write_bytes(data)
    argv = ["thermal", step, recording, "--channel", "gyro_x", "--calibration", calibration]
    argv += ["--out", out / "c.csv"] if step == "compensate" else ["--json", out / "u.json"]
    code, stdout, stderr = run_cli(*argv)
    _check(code, stdout, stderr, out, argv)
    if step == "update":
        assert code == 2  # a short recording never reaches the sampler


def test_the_valid_calibration_compensates(run_cli, tmp_path):
    """The calibration the fuzz mutates is itself valid: compensate applies it exactly."""
    recording = tmp_path / "rec.csv"
    recording.write_text(GOOD)
    calibration = tmp_path / "cal.json"
    calibration.write_text(json.dumps(CALIBRATION))
    out = tmp_path / "c.csv"
    code, _, stderr = run_cli(
        "thermal", "compensate", recording, "--channel", "gyro_x", "--calibration", calibration,
        "--out", out,
    )  # fmt: skip
    assert code == 0, stderr
    table = np.genfromtxt(out, delimiter=",", names=True)
    rows = _rows(300)
    expected = rows[:, 1] - 0.4 - 0.001 * (rows[:, 5] - 25.0)
    np.testing.assert_allclose(table["gyro_x_compensated"], expected, rtol=0, atol=1e-9)
