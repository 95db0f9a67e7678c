"""Two-position calibration and local gravity: published gravity values, the classical numbers
against an independent computation, recovery of a simulated calibration, section finding,
and bad input."""

import json
import math
import warnings

import jax
import numpy as np
import pytest
from recording_files import write_csv
from scipy import stats

import bayescal as bc
from bayescal.classical._gravity import normal_gravity

RATE = 100.0
G = 9.80123
SCALE, OFFSET = 1.002, 0.05  # truth: reading = offset +- g / scale


def test_normal_gravity_reproduces_wgs84_published_values():
    # NIMA TR8350.2 (3rd ed.), table 3.4: normal gravity at the equator and at the poles.
    assert normal_gravity(0.0) == pytest.approx(9.7803253359, abs=1e-10)
    assert normal_gravity(90.0) == pytest.approx(9.8321849378, abs=1e-9)
    assert normal_gravity(-90.0) == pytest.approx(9.8321849378, abs=1e-9)
    # The free-air gradient is -0.3086 mGal per metre.
    gradient = normal_gravity(45.0, 100.0) - normal_gravity(45.0, 0.0)
    assert gradient / 100 == pytest.approx(-3.086e-6, rel=1e-3)


def test_local_gravity_computed_or_measured():
    given = bc.LocalGravity.measured(9.80123, 2e-5)
    assert (given.value, given.uncertainty) == (9.80123, 2e-5)
    computed = bc.local_gravity(40.1, 220.0)
    assert computed.value == pytest.approx(normal_gravity(40.1, 220.0)) and computed.uncertainty > 0
    with pytest.raises(bc.InputError, match="not a gravity"):
        bc.LocalGravity.measured(98.1)
    with pytest.raises(bc.InputError, match="uncertainty"):
        bc.LocalGravity.measured(9.81, -1.0)
    with pytest.raises(bc.InputError, match="latitude_deg"):
        bc.local_gravity(100.0)


def simulate_sections(seed, n=6000, **noise):
    model = bc.NoiseModel(rate_hz=RATE, **noise)
    keys = jax.random.split(jax.random.PRNGKey(seed), 2)
    up = OFFSET + G / SCALE + np.asarray(model.sample(keys[0], n))
    down = OFFSET - G / SCALE + np.asarray(model.sample(keys[1], n))
    return up, down


def test_classical_numbers_match_an_independent_computation():
    up, down = simulate_sections(1, N=0.0004)
    gravity = bc.LocalGravity.measured(9.80123, 0.0001)
    result = bc.calibrate_two_position(up, down, RATE, gravity=gravity, bayesian=False).classical

    def half_width(x):
        low, high = stats.t.interval(0.95, x.size - 1, loc=x.mean(), scale=stats.sem(x))
        return (high - low) / 2

    span = up.mean() - down.mean()
    u_span = math.sqrt(half_width(up) ** 2 + half_width(down) ** 2)
    g_half = 1.959963984540054 * 0.0001
    scale = 2 * 9.80123 / span
    expected = {
        "mean_up": (up.mean(), half_width(up)),
        "mean_down": (down.mean(), half_width(down)),
        "span": (span, u_span),
        "scale": (scale, scale * math.sqrt((u_span / span) ** 2 + (g_half / 9.80123) ** 2)),
        "offset": ((up.mean() + down.mean()) / 2, u_span / 2),
    }
    for name, (value, uncertainty) in expected.items():
        assert result[name][0] == pytest.approx(value, rel=1e-12), name
        assert result[name][1] == pytest.approx(uncertainty, rel=1e-9), name


def test_bayesian_recovers_scale_and_offset_with_a_random_walk():
    up, down = simulate_sections(2, N=0.0004, K=2e-4)
    gravity = bc.LocalGravity.measured(G, 0.00001)
    calibration = bc.calibrate_two_position(
        bc.Section(up, 0.0, "up"),
        bc.Section(down, 70.0, "down"),
        RATE,
        gravity=gravity,
        terms="white,rate_random_walk",
        gap_s=70.0,
        seed=0,
    )
    result, classical = calibration.bayesian, calibration.classical
    assert calibration.passed, result.noise.diagnostics.failures
    for name, truth in (("scale", SCALE), ("offset", OFFSET)):
        draws = np.ravel(result.draws[name])
        assert abs(draws.mean() - truth) <= 4 * draws.std(), name
    # The classical offset interval, blind to the random walk, is much narrower.
    assert np.std(result.draws["offset"]) > 3 * classical["offset"][1] / 1.96


@pytest.fixture
def session(tmp_path):
    """One file: up for 60 s, a 4 s turn over, down for 60 s, in m/s^2."""
    rng = np.random.default_rng(8)
    up, down = simulate_sections(3, N=0.0004)
    turn = np.linspace(0, np.pi, 400)
    z = np.concatenate(
        [up, OFFSET + G / SCALE * np.cos(turn) + 0.05 * rng.standard_normal(400), down]
    )
    x = np.concatenate(
        [0.01 * rng.standard_normal(6000), G * np.sin(turn), 0.01 * rng.standard_normal(6000)]
    )
    y = 0.01 * rng.standard_normal(z.size)
    rows = np.column_stack([np.arange(z.size) / RATE, x, y, z])
    columns = {"time": rows[:, 0], "acc_x[m/s^2]": x, "acc_y[m/s^2]": y, "acc_z[m/s^2]": z}
    return write_csv(tmp_path / "session.csv", columns, fmt="%.7f"), rows


def test_one_file_sections_are_found_and_reported(run_cli, tmp_path, session):
    path, _ = session
    output = tmp_path / "out.json"
    code, _stdout, stderr = run_cli(
        "two-position",
        path,
        "--channel",
        "acc_z",
        "--latitude",
        "40.1",
        "--height",
        "220",
        "--json",
        output,
        "--classical-only",
    )
    assert code == 0, stderr
    result = json.loads(output.read_text())
    sections = result["sections"]
    assert sections["up"]["start_s"] < 1.0 and 58 < sections["up"]["stop_s"] <= 60.01
    assert 64 <= sections["down"]["start_s"] < 65 and sections["down"]["stop_s"] > 123
    classical = result["classical"]
    assert set(classical) >= {"mean_up", "mean_down", "span", "scale", "offset"}
    for entry in ("mean_up", "mean_down", "span", "scale", "offset"):
        assert set(classical[entry]) == {"value", "uncertainty", "unit"}
    assert classical["scale"]["unit"] == "m/s^2/(m/s^2)" and classical["si"]["scale"]["unit"] == "1"
    assert abs(classical["offset"]["value"] - OFFSET) < 5 * classical["offset"]["uncertainty"]
    assert result["gravity"]["value"] == pytest.approx(normal_gravity(40.1, 220.0))


def test_a_bad_sample_on_another_axis_leaves_the_channel_to_find_its_sections(
    run_cli, tmp_path, session
):
    """The other axes only help to find the still stretches: an infinity in one of them (not
    the channel, which is checked on reading) once entered every running sum after it, and
    no stretch was still ('found 0 still sections', after numpy's warnings); the channel now
    judges alone. Called with one, find_static_sections names its argument."""
    _, rows = session
    rows = rows.copy()
    rows[10, 1] = np.inf
    names = ("time", "acc_x[m/s^2]", "acc_y[m/s^2]", "acc_z[m/s^2]")
    columns = dict(zip(names, rows.T, strict=True))
    path = write_csv(tmp_path / "bad_x.csv", columns, fmt="%.7f")
    output = tmp_path / "out.json"
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        code, _stdout, stderr = run_cli(
            "two-position", path, "--channel", "acc_z", "--latitude", "40.1", "--json",
            output, "--classical-only",
        )  # fmt: skip
    assert code == 0, stderr
    sections = json.loads(output.read_text())["sections"]
    assert sections["up"]["stop_s"] > 58 and sections["down"]["stop_s"] > 123
    refusal = r"values: 1 sample\(s\) not finite, the first at index 10"
    with pytest.raises(bc.InputError, match=refusal):
        bc.find_static_sections(rows[:, 1:], RATE)


def test_bayesian_json_contract(run_cli, tmp_path, session):
    path, _ = session
    output = tmp_path / "out.json"
    code, _, stderr = run_cli(
        "two-position",
        path,
        "--channel",
        "acc_z",
        "--g-local",
        f"{G}",
        "--terms",
        "white",
        "--json",
        output,
    )
    assert code == 0, stderr
    parameters = json.loads(output.read_text())["bayesian"]["parameters"]
    assert set(parameters) == {"scale", "offset", "g_local"}
    for entry in parameters.values():
        assert set(entry) == {"mean", "sd", "q05", "q95", "map", "map_sd", "unit"}
    assert parameters["scale"]["q05"] < SCALE < parameters["scale"]["q95"]


def write_section(path, values):
    time = np.arange(values.size) / RATE
    return write_csv(path, {"time": time, "acc_z[m/s^2]": values}, fmt="%.7f")


def test_bad_input(run_cli, tmp_path):
    up, down = simulate_sections(4, N=0.0004)
    up_file, down_file = (
        write_section(tmp_path / "up.csv", up),
        write_section(tmp_path / "down.csv", down),
    )
    cases = [
        (["--up", up_file], "one section is missing"),
        (["--up", up_file, "--down", up_file], "not opposite"),
        (
            [
                "--up",
                write_section(tmp_path / "tilt.csv", up + np.linspace(0, 0.3, up.size)),
                "--down",
                down_file,
            ],
            "not static",
        ),
        (
            [
                "--up",
                write_section(tmp_path / "g.csv", up / 9.80665),
                "--down",
                write_section(tmp_path / "g2.csv", down / 9.80665),
            ],
            "unit is probably wrong",
        ),
    ]
    for arguments, fragment in cases:
        code, stdout, stderr = run_cli(
            "two-position",
            *arguments,
            "--channel",
            "acc_z",
            "--g-local",
            "9.80123",
            "--classical-only",
        )
        assert code == 2 and fragment in stderr and stdout == "", (fragment, stderr)
