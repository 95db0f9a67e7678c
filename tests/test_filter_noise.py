"""The noise a navigation filter is told (bc.filter_noise, bayescal export-filter): every
estimator's convention against the values worked by hand in docs/guide/filter-config.md, the
files read back by YAML, OpenCV's FileStorage (the parser OpenVINS, ORB-SLAM3 and VINS use)
and GTSAM's PreintegrationCombinedParams where they are installed, and the command line."""

import json
import math
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

import bayescal as bc
from bayescal._errors import InputError
from bayescal.capabilities._estimators import ESTIMATORS, estimator
from bayescal.report._filter_config import filter_document, filter_file

# The worked example of docs/guide/filter-config.md: a gyro at 200 Hz with N = 0.005
# deg/s/sqrt(Hz), K = 1e-4 deg/s*sqrt(Hz), B = 0.002 deg/s; an accelerometer with N = 0.001
# m/s^2/sqrt(Hz), K = 2e-5 m/s^2*sqrt(Hz), no B. Horizon 600 s.
N_GYRO_RAD = 8.72664626e-05  # 0.005 * pi / 180
K_GYRO_RAD = 1.74532925e-06
Q_B_RAD = 2.83992e-06  # sqrt(9 (2 ln 2 / pi) 0.002^2 / 600) deg/s/sqrt(s), in rad
K_GYRO_TOTAL = 3.33336e-06  # sqrt(K^2 + q_B^2)
HAND = {
    # estimator -> gyro N value, gyro K value (its units, at 200 Hz; PX4 at its 100 Hz)
    "kalibr": (8.72665e-05, 3.33336e-06),
    "openvins": (8.72665e-05, 3.33336e-06),
    "orbslam3": (8.72665e-05, 3.33336e-06),
    "vins": (1.74533e-03, 4.71409e-05),  # sqrt(2) N sqrt(200) = 20 N; K sqrt(200)
    "gtsam": (7.61544e-09, 1.11113e-11),  # N^2, K^2
    "px4": (8.72665e-04, 3.33336e-05),  # N sqrt(100), K sqrt(100)
}


class _Summary(SimpleNamespace):
    pass


def fake_fit(channel, unit, values, terms, rate_hz=200.0, passed=True):
    """A NoiseFit whose posterior draws are all ``values`` (their quantiles are the values)."""
    draws = {name: np.full((4, 50), value) for name, value in values.items()}
    parameters = {name: _Summary(mean=value) for name, value in values.items()}
    posterior = SimpleNamespace(
        terms=terms,
        draws=draws,
        parameters=parameters,
        diagnostics=SimpleNamespace(passed=passed, failures=() if passed else ("R-hat 1.3",)),
    )
    classical = SimpleNamespace(slope_readings={}, duration_s=3600.0)
    return bc.NoiseFit(channel, unit, rate_hz, classical, fit=posterior)


def example_fits():
    gyro = fake_fit(
        "gyro_x",
        "deg/s",
        {"N": 0.005, "B": 0.002, "K": 1e-4},
        ("white", "bias_instability", "rate_random_walk"),
    )
    accel = fake_fit("acc_x", "m/s^2", {"N": 0.001, "K": 2e-5}, ("white", "rate_random_walk"))
    return [gyro, accel]


@pytest.mark.parametrize("name", sorted(ESTIMATORS))
def test_every_convention_matches_the_values_worked_by_hand(name):
    noise = bc.filter_noise(example_fits(), estimator=name, horizon=600.0)
    convention = estimator(name)
    gyro_n, gyro_k = HAND[name]
    values = noise.values
    assert values[convention.keys["gyroscope", "N"]]["value"] == pytest.approx(gyro_n, rel=1e-5)
    assert values[convention.keys["gyroscope", "K"]]["value"] == pytest.approx(gyro_k, rel=1e-5)
    items = noise.channels["gyro_x"].items
    assert items["posterior_quantile"][0].value == pytest.approx(N_GYRO_RAD, rel=1e-8)
    assert items["posterior_quantile"][1].value == pytest.approx(K_GYRO_RAD, rel=1e-8)
    assert items["bias_instability"][0].value == pytest.approx(Q_B_RAD, rel=1e-5)
    assert noise.channels["gyro_x"].density["K"] == pytest.approx(K_GYRO_TOTAL, rel=1e-5)
    # The accelerometer has no bias term: its K is the posterior's alone.
    accel = noise.channels["acc_x"]
    assert accel.items["bias_instability"] == ()
    assert accel.density["K"] == pytest.approx(2e-5, rel=1e-12)


@pytest.mark.parametrize("name", sorted(ESTIMATORS))
def test_values_round_trip_through_the_convention(name):
    convention = estimator(name)
    for parameter in ("N", "K"):
        for rate in (100.0, 400.0):
            value = convention.value(parameter, 3.7e-5, rate)
            assert convention.density(parameter, value, rate) == pytest.approx(3.7e-5, rel=1e-12)
    per_sample = {n for n, e in ESTIMATORS.items() if e.per_sample}
    assert per_sample == {"vins", "px4"}


def test_a_per_sample_value_scales_with_the_filter_rate_a_density_does_not():
    fits = example_fits()
    slow = bc.filter_noise(fits, estimator="px4", filter_rate_hz=100.0).values
    fast = bc.filter_noise(fits, estimator="px4", filter_rate_hz=400.0).values
    assert fast["EKF2_GYR_NOISE"]["value"] == pytest.approx(2 * slow["EKF2_GYR_NOISE"]["value"])
    kalibr = bc.filter_noise(fits, estimator="kalibr", filter_rate_hz=400.0).values
    assert kalibr["gyroscope_noise_density"]["value"] == pytest.approx(N_GYRO_RAD, rel=1e-6)


def test_a_longer_horizon_bounds_the_instability_by_a_smaller_walk():
    fits = example_fits()
    short = bc.filter_noise(fits, estimator="kalibr", horizon=60.0)
    long = bc.filter_noise(fits, estimator="kalibr", horizon=6000.0)
    short_q = short.channels["gyro_x"].items["bias_instability"][0].value
    long_q = long.channels["gyro_x"].items["bias_instability"][0].value
    assert short_q == pytest.approx(10 * long_q, rel=1e-9)  # q ~ 1 / sqrt(H)


@pytest.mark.parametrize(("kind", "sensor", "power", "factor"), [
    ("position", "accelerometer", 2, 0.5),
    ("velocity", "accelerometer", 1, 1.0),
    ("position", "gyroscope", 3, 9.80665 / 6),
    ("velocity", "gyroscope", 2, 9.80665 / 2),
])  # fmt: skip
def test_the_aiding_reveals_a_bias_as_least_squares_does(kind, sensor, power, factor):
    """The asymptotic C_p of navigation/_aiding.py against the exact least-squares variance
    of the leading coefficient of a polynomial fitted to fixes every second over 10 min."""
    aiding = bc.Aiding(kind, sd=0.7, interval_s=1.0)
    t = np.arange(0.5, 600.0, 1.0)
    design = np.vander(t, power + 1, increasing=True)
    exact = 0.7 * math.sqrt(np.linalg.inv(design.T @ design)[power, power]) / factor
    assert aiding.revealed_bias_sd(sensor, 600.0) == pytest.approx(exact, rel=0.01)


def test_each_channel_s_horizon_follows_from_the_aiding():
    fits = example_fits()
    noise = bc.filter_noise(fits, estimator="kalibr")  # the default aiding: 1 m every 1 s
    # The gyro's bias is flicker alone beside the walk: sigma_A = sqrt(2 ln 2 / pi) B at every
    # tau, and s(T) = sqrt(2800 / T) 1 m / (g / 6 T^3) equals it at T^3.5 = 6 sqrt(2800) / (g
    # sigma_A), SI.
    sigma = math.sqrt(2 * math.log(2) / math.pi) * 0.002 * math.pi / 180
    expected = (6 * math.sqrt(2800) / (9.80665 * sigma)) ** (1 / 3.5)
    assert noise.channels["gyro_x"].horizon_s == pytest.approx(expected, rel=1e-6)
    q = noise.channels["gyro_x"].items["bias_instability"][0].value
    assert q == pytest.approx(Q_B_RAD * math.sqrt(600.0 / expected), rel=1e-6)
    assert noise.horizon_s is None and "assumed" in noise.notes[-1]
    # A finer aiding sees the bias sooner: a shorter horizon, a larger walk.
    finer = bc.filter_noise(fits, estimator="kalibr", aiding=bc.Aiding("position", 0.01, 0.1))
    assert finer.channels["gyro_x"].horizon_s < expected / 3
    assert "assumed" not in finer.notes[-1]
    document = filter_document(finer)
    assert document["aiding"] == {"kind": "position", "sd": 0.01, "unit": "m", "interval_s": 0.1}
    assert document["channels"]["gyro_x"]["horizon_s"] == finer.channels["gyro_x"].horizon_s
    with pytest.raises(InputError, match="give one"):
        bc.filter_noise(fits, estimator="kalibr", horizon=60.0, aiding=bc.Aiding())
    with pytest.raises(InputError, match="kind"):
        bc.Aiding("gnss", 1.0, 1.0)
    with pytest.raises(InputError, match="interval_s"):
        bc.Aiding("position", 1.0, 0.0)


def _parsed(name: str, text: str, tmp_path) -> dict:
    """The file read as its estimator reads it: name -> value."""
    convention = estimator(name)
    keys = list(convention.keys.values())
    if name in ("openvins", "orbslam3", "vins"):
        cv2 = pytest.importorskip("cv2")
        path = tmp_path / "file.yaml"
        path.write_text(text)
        storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
        node = storage.getNode("imu0") if name == "openvins" else storage.root()
        found = {key: node.getNode(key).real() for key in keys}
        storage.release()
        return found
    if name == "px4":
        rows = [line.split("\t") for line in text.splitlines() if not line.startswith("#")]
        assert all(len(row) == 5 and row[4] == "9" for row in rows if row != [""])
        return {row[2]: float(row[3]) for row in rows if len(row) == 5}
    content = yaml.safe_load(text)
    if name == "gtsam":
        block = content["PreintegrationCombinedParams"]
        return {key: np.asarray(block[key])[0, 0] for key in keys}
    return {key: content[key] for key in keys}


@pytest.mark.parametrize("name", sorted(ESTIMATORS))
def test_each_file_parses_and_its_values_round_trip(name, tmp_path):
    noise = bc.filter_noise(example_fits(), estimator=name, horizon=600.0)
    text = filter_file(noise)
    parsed = _parsed(name, text, tmp_path)
    for key, entry in noise.values.items():
        assert parsed[key] == pytest.approx(entry["value"], rel=1e-8), key
    document = json.loads(json.dumps(filter_document(noise, "x")))
    gyro = document["channels"]["gyro_x"]
    assert set(gyro["items"]) == {"posterior_quantile", "bias_instability", "vibration", "thermal"}
    assert gyro["items"]["vibration"]["value"] is None
    for key, entry in gyro["values"].items():
        assert entry["value"] == pytest.approx(noise.values[key]["value"], rel=1e-12)


def test_the_gtsam_values_load_into_gtsam(tmp_path):
    gtsam = pytest.importorskip("gtsam")
    noise = bc.filter_noise(example_fits(), estimator="gtsam", horizon=600.0)
    block = yaml.safe_load(filter_file(noise))["PreintegrationCombinedParams"]
    params = gtsam.PreintegrationCombinedParams.MakeSharedU(9.81)
    params.setGyroscopeCovariance(np.array(block["gyroscopeCovariance"]))
    params.setAccelerometerCovariance(np.array(block["accelerometerCovariance"]))
    params.setBiasOmegaCovariance(np.array(block["biasOmegaCovariance"]))
    params.setBiasAccCovariance(np.array(block["biasAccCovariance"]))
    assert params.getGyroscopeCovariance()[0, 0] == pytest.approx(HAND["gtsam"][0], rel=1e-5)
    assert params.getBiasOmegaCovariance()[2, 2] == pytest.approx(HAND["gtsam"][1], rel=1e-5)
    assert params.getBiasAccCovariance()[1, 1] == pytest.approx(4e-10, rel=1e-9)


def test_vibration_adds_its_excess_density_to_n():
    rate = 200.0
    gyro, accel = example_fits()
    rng = np.random.default_rng(4)
    # White at twice the static density: the excess is sqrt(4 - 1) N.
    shaking = 2 * 0.005 * math.sqrt(rate) * rng.standard_normal(2**15)
    noise = bc.filter_noise([gyro, accel], estimator="kalibr", vibration={"gyro_x": shaking})
    extra = noise.channels["gyro_x"].items["vibration"][0].value
    assert extra == pytest.approx(math.sqrt(3) * N_GYRO_RAD, rel=0.05)
    # Through the sensor's output filter the vibration is read before it: its density
    # divided by the fitted filter's gain.
    filtered = fake_fit(
        "gyro_x", "deg/s", {"N": 0.005, "F": 0.3}, ("white", "output_filter"), rate_hz=rate
    )
    shaking = bc.NoiseModel(rate_hz=rate, N=0.01, F=0.3).simulate(2**15, seed=5)
    noise = bc.filter_noise([filtered], estimator="kalibr", vibration={"gyro_x": shaking})
    extra = noise.channels["gyro_x"].items["vibration"][0]
    assert extra.value == pytest.approx(math.sqrt(3) * N_GYRO_RAD, rel=0.05)
    assert "output_filter's gain" in extra.how
    with pytest.raises(InputError, match="gyro_y is not among"):
        bc.filter_noise([gyro], estimator="kalibr", vibration={"gyro_y": shaking})


def test_a_thermal_calibration_adds_a_walk_to_k():
    gyro = example_fits()[0]
    calibration = SimpleNamespace(covariance=np.diag([1e-8, 1e-10]), unit="deg/s", channel="gyro_x")
    noise = bc.filter_noise(
        [gyro], estimator="kalibr", horizon=600.0, thermal={"gyro_x": (calibration, 10.0)}
    )
    item = noise.channels["gyro_x"].items["thermal"][0]
    # sd of the change over 10 degC: 10 * 1e-5 deg/s; a walk reaching it at 600 s.
    assert item.value == pytest.approx(1e-4 * math.pi / 180 / math.sqrt(600.0), rel=1e-9)


def test_bad_arguments_name_themselves():
    fits = example_fits()
    with pytest.raises(InputError, match="estimator='rovio'"):
        bc.filter_noise(fits, estimator="rovio")
    with pytest.raises(InputError, match="horizon"):
        bc.filter_noise(fits, estimator="kalibr", horizon=-1.0)
    with pytest.raises(InputError, match="quantile"):
        bc.filter_noise(fits, estimator="kalibr", quantile=1.5)
    counts = fake_fit("raw", "LSB", {"N": 1.0}, ("white",))
    with pytest.raises(InputError, match="'LSB'"):
        bc.filter_noise(counts, estimator="kalibr")


def test_a_failed_posterior_is_said_and_checked():
    gyro = fake_fit("gyro_x", "deg/s", {"N": 0.005, "K": 1e-4}, ("white", "rate_random_walk"))
    bad = fake_fit(
        "gyro_y", "deg/s", {"N": 0.005, "K": 1e-4}, ("white", "rate_random_walk"), passed=False
    )
    noise = bc.filter_noise([gyro, bad], estimator="kalibr")
    assert not noise.passed and "gyro_y" in noise.failures[0]
    with pytest.raises(bc.HealthCheckError, match="gyro_y"):
        noise.check()
    assert "HEALTH CHECK FAILED" in filter_file(noise)


def test_export_filter_command(run_cli, tmp_path):
    """The command end to end on a short simulated record: the file, the JSON, exit 0."""
    n = 2**13
    gyro = bc.NoiseModel(rate_hz=100.0, N=0.005, K=1e-4).simulate(n, seed=1)
    accel = bc.NoiseModel(rate_hz=100.0, N=0.001, K=2e-5).simulate(n, seed=2)
    csv = tmp_path / "imu.csv"
    table = np.column_stack([np.arange(n) / 100.0, gyro, accel])
    np.savetxt(csv, table, delimiter=",", header="time,gyro_x[deg/s],acc_x[m/s^2]", comments="")
    out, document = tmp_path / "imu.yaml", tmp_path / "out.json"
    code, stdout, stderr = run_cli(
        "export-filter", csv, "--channels", "gyro_x,acc_x", "--estimator", "kalibr",
        "--terms", "white,rrw", "--horizon", "300", "--out", out, "--json", document, "--quiet",
    )  # fmt: skip
    assert code == 0, stderr
    for wrong in ("gnss:1@1", "position:1", "position:-1@1"):
        code, _, stderr = run_cli(
            "export-filter", csv, "--estimator", "kalibr", "--aiding", wrong, "--out", out,
        )  # fmt: skip
        assert code == 2 and "--aiding" in stderr and "Traceback" not in stderr
    written = yaml.safe_load(out.read_text())
    result = json.loads(document.read_text())
    for key in ("gyroscope_noise_density", "accelerometer_random_walk"):
        assert written[key] == pytest.approx(result["values"][key]["value"], rel=1e-8)
    assert result["channels"]["gyro_x"]["items"]["posterior_quantile"]["N"]["unit"] == (
        "rad/s/sqrt(Hz)"
    )
    assert "gyroscope_noise_density" in stdout


def test_within_spec_states_the_density_convention():
    # N = 0.005 deg/s/sqrt(Hz) = 0.3 deg/sqrt(h): draws spread around it.
    rng = np.random.default_rng(0)
    fit = fake_fit("gyro_x", "deg/s", {"N": 0.005, "K": 1e-4}, ("white", "rate_random_walk"))
    draws = 0.005 * np.exp(0.01 * rng.standard_normal((4, 500)))
    fit.fit.draws["N"] = draws
    limit, label = "N<0.0052 deg/s/sqrt(Hz)", "N < 0.0052 deg/s/sqrt(Hz)"
    two = bc.within_spec(fit, limit).summary[label]
    one = bc.within_spec(fit, limit, psd="one_sided").summary[label]
    assert two["probability"] == pytest.approx(np.mean(draws <= 0.0052))
    assert two["probability"] > 0.99
    # One-sided: the datasheet's 0.0052 is sqrt(2) N, so N must be below 0.00368.
    assert one["limit_used"] == pytest.approx(0.0052 / math.sqrt(2))
    assert one["probability"] == 0.0 and "one-sided" in one["convention"]
    with pytest.raises(InputError, match="psd"):
        bc.within_spec(fit, limit, psd="both")
