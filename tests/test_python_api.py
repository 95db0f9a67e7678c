"""The library speaks Python (issue 39 item 4, issue 32 item 5, issue 40): its messages name
arguments, not the command line's flags; a missing file is a FileNotFoundError; a misspelt
keyword is named as written against the public function; every capability takes a Channel
and gives a result with a ``summary``; one ``Sampler`` object and ``rate_hz`` everywhere; and
arrays meant to lie on one sample grid are checked against each other, the error naming both
arguments and their lengths."""

import ast
import functools
import inspect
import re
from pathlib import Path

import numpy as np
import pytest

import bayescal as bc
from bayescal.cli._flags import in_flags
from bayescal.cli._main import build_parser

PACKAGE = Path(bc.__file__).parent
FLAG = re.compile(r"(?<![\w-])--[a-z][a-z-]*")
RATE = 20.0
QUICK = bc.Sampler(max_steps=500)
"""A sampler too short to converge: these tests check what a call takes and gives, not the
posterior."""

NOT_YET = {
    "models/_terms.py": 5,
    "models/_thermal.py": 1,
    "models/effects/earth_rotation.py": 3,
    "inference/_priors.py": 2,
}
"""Messages that still name a flag, in the modules the noise-term restructuring (issue 32
item 1) rewrites and this change does not touch: their count may only fall."""


def _message_strings(tree: ast.AST):
    """The string pieces of what a module raises: raise statements, calls of an ``*Error`` /
    ``*_error`` constructor, and the ``fix``/``problem``/``message``/``argument`` texts built
    for them."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Raise) and node.exc is not None:
            yield from _strings(node.exc)
        elif isinstance(node, ast.Call):
            func = node.func
            name = getattr(func, "id", None) or getattr(func, "attr", "")
            if name.lower().endswith("error"):
                yield from _strings(node)
        elif isinstance(node, ast.Assign) and any(
            getattr(target, "id", None) in ("fix", "problem", "message", "argument")
            for target in node.targets
        ):
            yield from _strings(node.value)


def _strings(node: ast.AST):
    for sub in ast.walk(node):
        if isinstance(sub, ast.Constant) and isinstance(sub.value, str):
            yield sub


def test_no_library_message_mentions_a_command_line_flag():
    """The layers of the Python API (everything but cli/ and report/, the command line's
    side) name arguments in their error messages (``gaps="split"``), never flags."""
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        relative = path.relative_to(PACKAGE).as_posix()
        if relative.startswith(("cli/", "report/")):
            continue
        texts = {id(node): node.value for node in _message_strings(ast.parse(path.read_text()))}
        flags = [text for text in texts.values() if FLAG.search(text)]
        if flags:
            found[relative] = flags
    for relative, allowed in NOT_YET.items():
        assert len(found.pop(relative, [])) <= allowed, relative
    assert not found, found


@pytest.mark.parametrize(
    ("library", "command_line"),
    [
        ('pass gaps="split", or pick a window with start=/stop=', "--gaps split"),
        ("pick a window with start=/stop=", "--start/--stop"),
        ("pass rate_hz=HZ or time_column=NAME", "--rate HZ or --time-column NAME"),
        ("min_still_s=1.5 finds 42 poses", "--min-still 1.5 finds 42 poses"),
        ("pass unit='g'", "pass --unit g"),
        ('pass accel_columns=("X", "Y", "Z")', "--accel-columns X,Y,Z"),
        ('say which with names={"VAR": ["a", "b"]}', "--names VAR:a,b"),
        ("latitude_deg=95 must lie between -90 and 90", "--latitude 95 must"),
    ],
)
def test_the_command_line_says_its_flags(library, command_line):
    assert command_line in in_flags(library, build_parser())


def test_a_library_error_reaches_the_command_line_as_flags(run_cli, tmp_path):
    """A gap refused by the loader (the library says ``gaps="split"``) is told to a user of
    the command line with its flag."""
    time = np.arange(600) / 100.0
    time[300:] += 5.0
    rows = "\n".join(f"{t:.3f},{0.01 * np.sin(7 * t):.6f}" for t in time)
    path = tmp_path / "gap.csv"
    path.write_text(f"time,gyro_x\n{rows}\n")
    code, _, stderr = run_cli("noise", path, "--channel", "gyro_x", "--classical-only")
    assert code == 2 and "--gaps split" in stderr and 'gaps="split"' not in stderr, stderr


def test_a_missing_file_is_a_file_not_found_error(tmp_path):
    """Each reader of a file: a FileNotFoundError (the path as its filename) that is also an
    InputError (the command line's exit 2)."""
    missing = tmp_path / "missing"
    manifest = tmp_path / "fleet.csv"
    manifest.write_text("path,unit\nnot_there.csv,U1\n")
    calls = {
        "load_recording": lambda: bc.load_recording(missing.with_suffix(".csv")),
        "stream_channel": lambda: bc.stream_channel(missing.with_suffix(".parquet"), "x"),
        "read_manifest": lambda: bc.read_manifest(missing.with_suffix(".csv")),
        "a manifest's row": lambda: bc.read_manifest(manifest),
        "load_thermal_calibration": lambda: bc.load_thermal_calibration(missing),
        "a ROS bag": lambda: bc.load_recording(missing.with_suffix(".bag")),
    }
    for name, call in calls.items():
        with pytest.raises(FileNotFoundError) as error:
            call()
        assert isinstance(error.value, bc.InputError), name
        assert "no such" in str(error.value) and error.value.filename, name


def test_a_misspelt_keyword_is_named_as_written():
    recording = bc.Recording("<test>", {"gyro_x": np.zeros(300)}, {"gyro_x": "deg/s"})
    with pytest.raises(TypeError, match=r"Recording\.channel\(\) got an unexpected keyword "
                       r"argument 'rat'") as error:  # fmt: skip
        recording.channel("gyro_x", rat=100.0)
    assert "prepare_channel" not in str(error.value)
    for function in (bc.fit_noise, bc.fit_thermal, bc.discover, bc.calibrate_two_position):
        with pytest.raises(TypeError, match=rf"{function.__name__}\(\) got an unexpected"):
            function(np.zeros(300), n_walkers=64)


def _public_callables():
    """Every public function, and every public method of a public class."""
    for name in bc.__all__:
        value = getattr(bc, name)
        if inspect.isfunction(value):
            yield name, value
        elif inspect.isclass(value):
            for member, attribute in vars(value).items():
                if inspect.isfunction(attribute) and not member.startswith("_"):
                    yield f"{name}.{member}", attribute


def test_one_signature_style():
    """``rate_hz`` everywhere, and every capability that samples takes one ``sampler`` (a
    ``bc.Sampler``) and none of the keywords it replaced; ``seed`` stays a keyword."""
    samplers = set()
    for name, function in _public_callables():
        parameters = inspect.signature(function).parameters
        assert "rate" not in parameters, name
        assert not {"n_walkers", "max_steps"} & set(parameters), name
        if "sampler" in parameters:
            assert "progress" not in parameters, name
            assert parameters["sampler"].default == bc.Sampler(), name
            assert "seed" in parameters, name
            samplers.add(name)
    assert samplers == {
        "fit_noise",
        "calibrate_two_position",
        "calibrate_multi_position",
        "fit_thermal",
        "ThermalCalibration.update",
        "discover",
        "fit_fleet",
        "infield_update",
    }


def test_the_sampler_settings_are_checked_and_used():
    with pytest.raises(bc.InputError, match="n_walkers=1"):
        bc.Sampler(n_walkers=1)
    with pytest.raises(bc.InputError, match=r"max_steps=0\.5"):
        bc.Sampler(max_steps=0.5)
    y = bc.NoiseModel(rate_hz=RATE, N=0.01).simulate(2**11, seed=1)
    with pytest.raises(bc.InputError, match=r"sampler=64 is not a bayescal\.Sampler"):
        bc.fit_noise(y, RATE, terms="white", sampler=64)
    fit = bc.fit_noise(y, RATE, terms="white", sampler=bc.Sampler(n_walkers=40, max_steps=600))
    assert fit.diagnostics.n_walkers == 40 and fit.diagnostics.n_steps <= 600


# ---------------------------------------------------------------------------------------------
# Channels, summaries and shapes


@pytest.fixture(scope="module")
def imu():
    """A warming gyro with a thermal bias, its temperature and an accelerometer, as a
    recording in memory (12 minutes at 20 Hz, the length of tests/test_discover.py's records:
    the discovery's compiled functions serve both)."""
    n = 12 * 60 * int(RATE)
    t = np.arange(n) / RATE
    temperature = 25 + 10 * (1 - np.exp(-t / 100))
    gyro = bc.NoiseModel(rate_hz=RATE, N=0.01).simulate(n, seed=4) + 0.004 * (temperature - 30)
    accelerometer = 9.81 + 0.01 * np.random.default_rng(5).standard_normal(n)
    return bc.Recording(
        "<imu>",
        {"time": t, "gyro_z": gyro, "temperature": temperature, "acc_z": accelerometer},
        {"gyro_z": "deg/s", "acc_z": "m/s^2", "temperature": "degC"},
    )


@pytest.fixture(scope="module")
def gyro(imu):
    return imu.channel("gyro_z", temperature="temperature")


@pytest.fixture(scope="module")
def thermal(gyro):
    return bc.fit_thermal(gyro, degree=1, terms="white", sampler=QUICK)


@pytest.fixture(scope="module")
def found(gyro):
    return bc.discover(gyro, posterior=False)


def test_every_capability_takes_a_channel(imu, gyro, thermal, found):
    """A Channel brings its samples, rate, unit, name (and, prepared with one, its
    temperature) to every capability; the result is the one its arrays give."""
    y, temperature = gyro.values, gyro.temperature
    noise = bc.fit_noise(gyro, terms="white", sampler=QUICK)
    assert (noise.channel, noise.unit, noise.rate_hz) == ("gyro_z", "deg/s", RATE)
    same = bc.fit_noise(y, RATE, terms="white", sampler=QUICK, unit="deg/s")
    assert noise.summary == same.summary
    assert (found.channel, found.unit) == ("gyro_z", "deg/s")
    assert [effect.name for effect in found.effects] == ["thermal_bias"]
    assert (thermal.channel, thermal.unit, thermal.provenance[0]["source"]) == (
        "gyro_z",
        "deg/s",
        "<imu>",
    )
    from_arrays = bc.fit_thermal(y, temperature, RATE, degree=1, terms="white", sampler=QUICK)
    np.testing.assert_array_equal(thermal.coefficients, from_arrays.coefficients)
    updated = thermal.update(gyro, drift=0.0, sampler=QUICK)
    assert updated.provenance[-1]["source"] == "<imu>"
    compensated, _ = thermal.compensate(gyro)
    np.testing.assert_array_equal(compensated, thermal.compensate(y, temperature)[0])
    with pytest.raises(bc.InputError, match="the calibration is in deg/s but the channel"):
        thermal.compensate(imu.channel("acc_z"))
    np.testing.assert_array_equal(
        bc.allan_deviation(gyro).deviation, bc.allan_deviation(y, RATE).deviation
    )
    assert bc.classical_noise(gyro).bias == bc.classical_noise(y, RATE).bias
    assert bc.find_static_sections(gyro) == bc.find_static_sections(y, RATE)


def test_the_calibrations_take_channels():
    g = bc.local_gravity(45.0)
    rng = np.random.default_rng(0)
    n = 1200
    table = bc.Recording(
        "<session>",
        {
            "time": np.arange(n) / 100.0,
            "up": 0.03 + g.value / 1.002 + 0.004 * rng.standard_normal(n),
            "down": 0.03 - g.value / 1.002 + 0.004 * rng.standard_normal(n),
        },
        {"up": "m/s^2", "down": "m/s^2"},
    )
    up, down = table.channel("up", at_rest=False), table.channel("down", at_rest=False)
    calibration = bc.calibrate_two_position(up, down, gravity=g, bayesian=False)
    assert (calibration.rate_hz, calibration.unit, calibration.channel) == (100.0, "m/s^2", "up")
    arrays = bc.calibrate_two_position(up.values, down.values, 100.0, gravity=g, bayesian=False)
    assert calibration.classical == arrays.classical
    other = bc.Recording("<other>", {"x": up.values}, {"x": "g"}).channel(
        "x", rate_hz=100.0, at_rest=False
    )
    with pytest.raises(bc.InputError, match="up and down differ"):
        bc.calibrate_two_position(up, other, gravity=g, bayesian=False)


def test_three_channels_make_a_multi_position_session():
    directions = np.random.default_rng(17).standard_normal((14, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    readings = np.repeat(9.80123 * directions, 300, axis=0)
    readings += 0.002 * np.random.default_rng(3).standard_normal(readings.shape)
    columns = {"time": np.arange(readings.shape[0]) / 100.0}
    columns |= {f"acc_{axis}": readings[:, i] for i, axis in enumerate("xyz")}
    table = bc.Recording("<poses>", columns, dict.fromkeys(("acc_x", "acc_y", "acc_z"), "m/s^2"))
    axes = [table.channel(f"acc_{axis}", at_rest=False) for axis in "xyz"]
    gravity = bc.LocalGravity.measured(9.80123)
    calibration = bc.calibrate_multi_position(axes, gravity=gravity, bayesian=False)
    arrays = bc.calibrate_multi_position(readings, 100.0, gravity=gravity, bayesian=False)
    assert calibration.classical.parameters == arrays.classical.parameters
    assert set(calibration.summary) == set(calibration.classical.names)
    assert calibration.summary["scale_x"]["unit"] == "1"
    shorter = table.channel("acc_z", stop=20.0, at_rest=False)
    with pytest.raises(bc.InputError, match="not on one grid"):
        bc.calibrate_multi_position([*axes[:2], shorter], gravity=gravity, bayesian=False)


def test_every_result_has_a_summary(thermal, found):
    """Each capability's result has ``summary``: its parameters, each with its unit."""
    for name in (
        "NoiseFit",
        "TwoPositionCalibration",
        "MultiPositionCalibration",
        "ThermalCalibration",
        "Discovery",
        "FleetFit",
    ):
        summary = inspect.getattr_static(getattr(bc, name), "summary")
        assert isinstance(summary, (property, functools.cached_property)), name
    g = bc.local_gravity(45.0)
    rng = np.random.default_rng(1)
    up = g.value + 0.004 * rng.standard_normal(2000)
    down = -g.value + 0.004 * rng.standard_normal(2000)
    two = bc.calibrate_two_position(up, down, 100.0, gravity=g, terms="white", sampler=QUICK)
    assert set(two.summary) == {"scale", "offset", "g_local"}
    assert two.summary["scale"]["unit"] == "m/s^2/(m/s^2)" and "q95" in two.summary["scale"]
    classical = bc.calibrate_two_position(up, down, 100.0, gravity=g, bayesian=False)
    assert classical.summary["offset"]["half_width"] == classical.classical["offset"][1]
    assert thermal.summary["c1"]["unit"] == "deg/s/degC" and thermal.summary["N"]["unit"]
    assert thermal.summary["c1"]["q05"] < thermal.summary["c1"]["mean"]
    assert found.summary == {"thermal_bias": {}}  # no final posterior: no parameters


def _calibration() -> "bc.ThermalCalibration":
    """A calibration made directly (no fit): c0 = 0.5 deg/s, c1 = 0.01 deg/s/degC at 30."""
    return bc.ThermalCalibration(
        channel="gyro_z",
        unit="deg/s",
        temperature_unit="degC",
        reference=30.0,
        degree=1,
        coefficients=np.array([0.5, 0.01]),
        covariance=np.diag([1e-6, 1e-8]),
        temperature_range=(25.0, 35.0),
        noise={"terms": ["white"], "N": {"mean": 0.005, "q05": 0.004, "q95": 0.006}},
        earth_rate=None,
        provenance=(),
        bayesian={},
    )


N_SAMPLES = 2**10
Y = bc.NoiseModel(rate_hz=RATE, N=0.005).simulate(N_SAMPLES, seed=1)
T = np.linspace(25.0, 35.0, N_SAMPLES)
SHORT = T[:100]
MISMATCHED = {
    "discover": (
        lambda: bc.discover(Y, RATE, temperature=SHORT),
        "temperature has 100 values but y has 1024",
    ),
    "discover (accelerometers)": (
        lambda: bc.discover(Y, RATE, accelerometers={"acc_z": SHORT}),
        "accelerometers['acc_z'] has 100 values but y has 1024",
    ),
    "fit_thermal": (
        lambda: bc.fit_thermal(Y, SHORT, RATE),
        "temperature has 100 values but y has 1024",
    ),
    "ThermalCalibration.update": (
        lambda: _calibration().update(Y, SHORT, RATE),
        "temperature has 100 values but y has 1024",
    ),
    "ThermalCalibration.compensate": (
        lambda: _calibration().compensate(Y, SHORT),
        "temperature has 100 values but y has 1024",
    ),
    "deviation_interval": (
        lambda: bc.deviation_interval(np.ones(5), np.ones(3), 0.95),
        "edf has shape (3,) but deviation has (5,)",
    ),
    "Poses.from_samples": (
        lambda: bc.Poses.from_samples([np.ones((5, 3)), np.ones((5, 3))], start_s=[0.0]),
        "start_s has 1 values but samples has 2",
    ),
}
"""Every public function whose array arguments must match, called with mismatched ones, and
the error it must give."""
ARRAYS = {"temperature", "accelerometers", "edf", "start_s", "stop_s"}
"""Arguments that must match another array argument of their function (one of REFERENCES); a
new public function with both is listed in MISMATCHED or the test fails."""
REFERENCES = {"y", "deviation", "samples"}


@pytest.mark.parametrize("name", sorted(MISMATCHED))
def test_mismatched_lengths_are_named(name):
    call, message = MISMATCHED[name]
    with pytest.raises(bc.InputError, match=re.escape(message)):
        call()


def test_every_function_with_matching_arrays_is_walked():
    checked = {name.split(" ")[0] for name in MISMATCHED}
    for name, function in _public_callables():
        parameters = inspect.signature(function).parameters
        arrays = [
            argument
            for argument in ARRAYS & set(parameters)
            if "str" not in str(parameters[argument].annotation)  # a column's name
        ]
        if arrays and REFERENCES & set(parameters):
            assert name in checked, f"{name}: no case in MISMATCHED"
