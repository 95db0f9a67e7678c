"""ROS bags in, Kalibr and MATLAB out: a simulated gyro written into ROS 1 and ROS 2 bags by
rosbags' own writers reads back exactly as the same data in a CSV, and the exported imu.yaml
and gyroparams/accelparams script carry the numbers of ``bayescal noise --json``."""

import json
import re

import numpy as np
import pytest
from recording_files import write_csv

import bayescal as bc

yaml = pytest.importorskip("yaml")  # PyYAML, which Kalibr reads its imu.yaml with
pytest.importorskip("rosbags")

RATE = 100.0
N_SAMPLES = 4096
START_NS = 1_700_000_000_123_456_789
G = 9.80665


def _simulated_imu(seed=3):
    """A static IMU in SI units: white noise plus a slow rate random walk on each axis."""
    rng = np.random.default_rng(seed)
    walk = np.cumsum(rng.standard_normal((N_SAMPLES, 6)), axis=0) * 2e-6
    gyro = 0.003 + 1e-4 * np.sqrt(RATE) * rng.standard_normal((N_SAMPLES, 3)) + walk[:, :3]
    acc = np.array([0.02, -0.01, G]) + 2e-3 * np.sqrt(RATE) * rng.standard_normal((N_SAMPLES, 3))
    return gyro, acc + 50 * walk[:, 3:]


def _imu_message(store, ros1, k, gyro, acc, stamp_ns, frame_id="imu_link"):
    types = store.types
    time = types["builtin_interfaces/msg/Time"](stamp_ns // 10**9, stamp_ns % 10**9)
    header_type = types["std_msgs/msg/Header"]
    header = header_type(k, time, frame_id) if ros1 else header_type(time, frame_id)
    vector = types["geometry_msgs/msg/Vector3"]
    zeros = np.zeros(9)
    return types["sensor_msgs/msg/Imu"](
        header,
        types["geometry_msgs/msg/Quaternion"](0.0, 0.0, 0.0, 1.0),
        zeros,
        vector(*gyro),
        zeros,
        vector(*acc),
        zeros,
    )


def write_bag(path, topics, *, kind="ros2", zero_stamps=False, frame_ids=None, strings=()):
    """Write ``topics`` ({name: (gyro, acc)}) as sensor_msgs/Imu, and ``strings`` topics of
    std_msgs/String, into a ROS 1 .bag (kind "ros1") or a ROS 2 bag (sqlite3 or mcap)."""
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2
    from rosbags.typesys import Stores, get_typestore

    ros1 = kind == "ros1"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.LATEST)
    if ros1:
        writer = Writer1(path)
    else:
        plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
        writer = Writer2(path, version=9, storage_plugin=plugin)
    serialize = store.serialize_ros1 if ros1 else store.serialize_cdr
    imu_type, string_type = "sensor_msgs/msg/Imu", "std_msgs/msg/String"
    with writer:
        for name in strings:
            connection = writer.add_connection(name, string_type, typestore=store)
            message = store.types[string_type]("hello")
            writer.write(connection, START_NS, serialize(message, string_type))
        for name, (gyro, acc) in topics.items():
            connection = writer.add_connection(name, imu_type, typestore=store)
            for k in range(len(gyro)):
                received = START_NS + k * 10_000_000 + 250_000  # recorded 0.25 ms later
                stamp = 0 if zero_stamps else received - 250_000
                frame_id = frame_ids[k % len(frame_ids)] if frame_ids else "imu_link"
                message = _imu_message(store, ros1, k, gyro[k], acc[k], stamp, frame_id)
                writer.write(connection, received, serialize(message, imu_type))
    return path


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    folder = tmp_path_factory.mktemp("formats")
    gyro, acc = _simulated_imu()
    topics = {"/imu": (gyro, acc)}
    bags = {
        "ros2": write_bag(folder / "run_ros2", topics),
        "mcap": write_bag(folder / "run_mcap", topics, kind="mcap") / "run_mcap.mcap",
        "ros1": write_bag(folder / "run.bag", topics, kind="ros1"),
    }
    bags["db3"] = folder / "run_ros2" / "run_ros2.db3"
    time = np.arange(N_SAMPLES) / RATE
    csv = write_csv(
        folder / "run.csv",
        {"time": time, "gyro_x[rad/s]": gyro[:, 0], "gyro_z[deg/s]": np.degrees(gyro[:, 2])}
        | {"acc_y[g]": acc[:, 1] / G},
    )
    return {"folder": folder, "bags": bags, "csv": csv, "gyro": gyro, "acc": acc}


def _noise_json(run_cli, path, tmp_path, *arguments):
    output = tmp_path / f"out{len(list(tmp_path.iterdir()))}.json"
    code, stdout, stderr = run_cli("noise", path, *arguments, "--classical-only", "--json", output)
    assert code == 0, stderr
    return json.loads(output.read_text()), stdout


def _without_source(result):
    return {key: value for key, value in result.items() if key != "source"}


@pytest.mark.parametrize("kind", ["ros2", "db3", "mcap", "ros1"])
def test_bag_reads_exactly_as_the_csv(run_cli, tmp_path, recordings, kind):
    """Round trip: the gyro written into a bag gives the CSV's numbers, every one of them."""
    bag = recordings["bags"][kind]
    from_bag, stdout = _noise_json(run_cli, bag, tmp_path, "--channel", "gyro_x")
    from_csv, _ = _noise_json(run_cli, recordings["csv"], tmp_path, "--channel", "gyro_x")
    assert from_bag["source"] == f"{bag} [/imu]" and from_bag["unit"] == "rad/s"
    assert from_bag["n_samples"] == N_SAMPLES and from_bag["rate_hz"] == RATE
    assert _without_source(from_bag) == _without_source(from_csv)
    assert "[/imu]" in stdout


def test_bag_columns_units_and_times(recordings):
    table = bc.load_recording(recordings["bags"]["ros1"], topic="/imu")
    assert table.topic == "/imu" and table.start_stamp_ns == START_NS
    assert table.header_units["gyro_y"] == "rad/s" and table.header_units["acc_z"] == "m/s^2"
    np.testing.assert_array_equal(table.columns["gyro_y"], recordings["gyro"][:, 1])
    np.testing.assert_array_equal(table.columns["acc_z"], recordings["acc"][:, 2])
    expected = np.arange(N_SAMPLES) / RATE
    np.testing.assert_allclose(table.columns["time"], expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(table.columns["bag_time"], expected, rtol=0, atol=1e-12)


def test_messages_of_varying_layout_read_through_rosbags(tmp_path):
    """frame_ids of different lengths move the CDR offsets: the slow, exact path reads them."""
    gyro, acc = _simulated_imu(seed=8)
    gyro, acc = gyro[:64], acc[:64]
    bag = write_bag(tmp_path / "odd", {"/imu": (gyro, acc)}, frame_ids=["a", "imu_link_12"])
    table = bc.load_recording(bag)
    np.testing.assert_array_equal(table.columns["gyro_x"], gyro[:, 0])
    np.testing.assert_array_equal(table.columns["acc_y"], acc[:, 1])


def test_topic_choice_and_bad_bags(run_cli, tmp_path, recordings):
    gyro, acc = recordings["gyro"][:256], recordings["acc"][:256]
    two = write_bag(
        tmp_path / "two", {"/imu": (gyro, acc), "/imu2": (gyro, acc)}, strings=["/status"]
    )
    code, _, stderr = run_cli("noise", two, "--channel", "gyro_x", "--classical-only")
    assert code == 2 and "2 sensor_msgs/Imu topics: /imu, /imu2" in stderr
    assert "--topic" in stderr
    code, _, stderr = run_cli("noise", two, "--topic", "/nope", "--channel", "gyro_x")
    assert code == 2 and "no topic '/nope'" in stderr and "IMU topics: /imu, /imu2" in stderr
    code, _, stderr = run_cli("noise", two, "--topic", "/status", "--channel", "gyro_x")
    assert code == 2 and "holds std_msgs/msg/String, not sensor_msgs/Imu" in stderr
    code, stdout, stderr = run_cli(
        "noise", two, "--topic", "/imu2", "--channel", "acc_z", "--classical-only"
    )
    assert code == 0, stderr
    assert "[/imu2]" in stdout and "m/s^2" in stdout

    no_imu = write_bag(tmp_path / "no_imu.bag", {}, kind="ros1", strings=["/status"])
    code, stdout, stderr = run_cli("noise", no_imu, "--channel", "gyro_x")
    assert code == 2 and stdout == ""
    assert "no_imu.bag: the bag has no sensor_msgs/Imu topic" in stderr
    assert "/status (std_msgs/msg/String)" in stderr

    broken = tmp_path / "broken.bag"
    broken.write_bytes(b"#ROSBAG V2.0\n" + b"\x00" * 40)
    code, _, stderr = run_cli("noise", broken, "--channel", "gyro_x")
    assert code == 2 and "broken.bag: cannot read it as a ROS bag" in stderr
    assert "Traceback" not in stderr and "internal error" not in stderr

    folder = tmp_path / "plain_folder"
    folder.mkdir()
    code, _, stderr = run_cli("noise", folder, "--channel", "gyro_x")
    assert code == 2 and "not a ROS 2 bag: it has no metadata.yaml" in stderr

    code, _, stderr = run_cli("noise", recordings["csv"], "--topic", "/imu", "--channel", "gyro_x")
    assert code == 2 and "only a ROS bag has topics" in stderr


def test_empty_header_stamps_need_another_clock(run_cli, tmp_path, recordings):
    gyro, acc = recordings["gyro"][:512], recordings["acc"][:512]
    bag = write_bag(tmp_path / "unstamped", {"/imu": (gyro, acc)}, zero_stamps=True)
    code, _, stderr = run_cli("noise", bag, "--channel", "gyro_x", "--classical-only")
    assert code == 2 and "no time column" in stderr and "bag_time" in stderr
    result, _ = _noise_json(
        run_cli, bag, tmp_path, "--channel", "gyro_x", "--time-column", "bag_time"
    )
    assert result["rate_hz"] == RATE


def _classical_si(result, parameter, to_si):
    reading = result["classical"]["slope_readings"][parameter]
    value = reading["value"] if reading["kind"] == "reading" else reading["ci_high"]
    return value * to_si


def test_kalibr_yaml_fills_one_sensor_per_run(run_cli, tmp_path, recordings):
    imu_yaml = tmp_path / "imu.yaml"
    gyro_result, stdout = _noise_json(
        run_cli,
        recordings["bags"]["ros2"],
        tmp_path,
        "--channel",
        "gyro_x",
        "--export",
        "kalibr",
        imu_yaml,
    )
    assert f"wrote gyroscope noise of gyro_x to {imu_yaml} (kalibr)" in stdout
    first = yaml.safe_load(imu_yaml.read_text())
    assert "accelerometer_noise_density" not in first
    assert "Accelerometers: not measured yet" in imu_yaml.read_text()

    # The accelerometer from a CSV in g: converted to m/s^2, the gyro entries kept.
    accel_result, stdout = _noise_json(
        run_cli, recordings["csv"], tmp_path, "--channel", "acc_y", "--export", "kalibr", imu_yaml
    )
    assert "gyroscope entries kept from the existing file" in stdout
    text = imu_yaml.read_text()
    imu = yaml.safe_load(text)
    kalibr_keys = {
        "accelerometer_noise_density",
        "accelerometer_random_walk",
        "gyroscope_noise_density",
        "gyroscope_random_walk",
        "rostopic",
        "update_rate",
    }
    assert kalibr_keys <= set(imu)
    for key in kalibr_keys - {"rostopic"}:
        assert isinstance(imu[key], float), (key, imu[key])
    assert imu["gyroscope_noise_density"] == pytest.approx(
        _classical_si(gyro_result, "N", 1.0), rel=1e-8
    )
    assert imu["gyroscope_random_walk"] == pytest.approx(
        _classical_si(gyro_result, "K", 1.0), rel=1e-8
    )
    assert imu["accelerometer_noise_density"] == pytest.approx(
        _classical_si(accel_result, "N", G), rel=1e-8
    )
    assert imu["accelerometer_random_walk"] == pytest.approx(
        _classical_si(accel_result, "K", G), rel=1e-8
    )
    assert imu["rostopic"] == "/imu" and imu["update_rate"] == RATE
    # Kalibr's conventions, said in the file.
    assert "[rad/s/sqrt(Hz)]" in text and "[m/s^3/sqrt(Hz)]" in text
    assert "rate random walk K" in text and "NOT the bias instability B" in text
    kept_line = next(line for line in text.splitlines() if line.startswith("# Gyroscopes:"))
    assert "kept from the file" in kept_line and "bias instability B = " in kept_line
    assert "accelerometer bias instability B =" in text
    assert "classical" in imu["bayescal"]["accelerometer"]["axes"]["acc_y"]["how"]["N"]


def test_matlab_script_sets_the_imusensor_properties(run_cli, tmp_path, recordings):
    script = tmp_path / "imu_params.m"
    result, _ = _noise_json(
        run_cli, recordings["csv"], tmp_path, "--channel", "gyro_z", "--export", "matlab", script
    )
    text = script.read_text()
    assert text.startswith("% IMU noise parameters for MATLAB's imuSensor, written by bayescal")
    assert "gyro = gyroparams;" in text and "accel = accelparams;" not in text
    to_si = np.pi / 180  # the channel is in deg/s; MATLAB wants rad/s
    for prop, parameter in (("NoiseDensity", "N"), ("BiasInstability", "B"), ("RandomWalk", "K")):
        match = re.search(rf"^gyro\.{prop} = ([-+.\deE]+);", text, re.MULTILINE)
        assert match, prop
        assert float(match[1]) == pytest.approx(_classical_si(result, parameter, to_si), rel=1e-8)
    assert "% gyro.TemperatureBias not set" in text
    assert "gyro_sample_rate = 100.0;" in text

    code, _, stderr = run_cli(
        "noise",
        recordings["bags"]["ros1"],
        "--channel",
        "acc_x",
        "--classical-only",
        "--export",
        "matlab",
        script,
    )
    assert code == 0, stderr
    merged = script.read_text()
    assert "accel = accelparams;" in merged and re.search(r"^accel\.RandomWalk = ", merged, re.M)
    gyro_block = text[text.index("%% gyroscope:") : text.index("%% end of gyroscope")]
    assert gyro_block in merged


def test_posterior_means_are_exported_when_the_posterior_passed():
    from types import SimpleNamespace

    from bayescal.report._export import (
        SensorNoise,
        kalibr_yaml,
        matlab_script,
        noise_estimates,
    )
    from bayescal.report._noise import NoiseAnalysis, Window

    def reading(kind, value, low, high):
        return bc.SlopeReading(value, low, high, 1.0, 0.0, kind, reason="no stretch")

    def summary(mean, q05, q95):
        return SimpleNamespace(mean=mean, q05=q05, q95=q95)

    classical = SimpleNamespace(
        slope_readings={
            "N": reading("reading", 2.0, 1.5, 2.5),
            "B": reading("upper_bound", None, None, 3.0),
            "K": reading("upper_bound", None, None, 5.0),
        },
        allan=SimpleNamespace(confidence=0.95),
    )

    def analysis(passed: bool) -> NoiseAnalysis:
        noise = SimpleNamespace(
            diagnostics=SimpleNamespace(passed=passed),
            parameters={"N": summary(2.1, 2.0, 2.2), "K": summary(0.4, 0.1, 0.8)},
        )
        return NoiseAnalysis("x.bag", "gyro_y", "rad/s", Window(0.0, 1.0), classical, noise)

    estimates = noise_estimates(analysis(True), to_si=10.0)
    assert estimates["N"].value == pytest.approx(21.0) and estimates["N"].how == "posterior mean"
    assert estimates["K"].value == pytest.approx(4.0)
    assert estimates["B"].value == pytest.approx(30.0) and "upper bound" in estimates["B"].how
    noise = SensorNoise("gyroscope", "gyro_y", "x.bag [/imu]", 200.0, estimates)
    text, kept = kalibr_yaml(noise, topic="/imu")
    assert kept is None
    imu = yaml.safe_load(text)
    assert imu["gyroscope_noise_density"] == pytest.approx(21.0)
    assert imu["gyroscope_random_walk"] == pytest.approx(4.0)
    assert "posterior mean, 90% interval [2.000e+01, 2.200e+01]" in text
    script, _ = matlab_script(
        SensorNoise("accelerometer", "acc_z", "f.csv", 100.0, estimates, temperature_bias=1e-4)
    )
    assert "accel.TemperatureBias = 1.000000000e-04;" in script

    fallback = noise_estimates(analysis(False), to_si=1.0)
    assert fallback["N"].value == 2.0 and "failed its health checks" in fallback["N"].how


def test_export_refusals_leave_no_file(run_cli, tmp_path, recordings):
    bag = recordings["bags"]["ros2"]

    def refused(*arguments, fragments):
        code, stdout, stderr = run_cli("noise", bag, "--channel", "gyro_x", *arguments)
        assert code == 2, stderr
        assert stdout == "" and "\n" not in stderr.strip()
        for fragment in fragments:
            assert fragment in stderr, stderr

    missing = tmp_path / "no_such_folder" / "imu.yaml"
    refused("--export", "kalibr", missing, fragments=["--export kalibr", "does not exist"])
    assert not missing.parent.exists()
    refused("--export", "rosparam", tmp_path / "x.yaml", fragments=["unknown format 'rosparam'"])
    refused("--export", "kalibr", tmp_path, fragments=["is a folder"])
    refused(
        "--unit", "LSB", "--export", "matlab", tmp_path / "lsb.m", fragments=["'LSB'", "--unit"]
    )
    assert not (tmp_path / "lsb.m").exists() and not (tmp_path / "x.yaml").exists()

    foreign = tmp_path / "other.yaml"
    foreign.write_text("cam0:\n  intrinsics: [1, 2, 3, 4]\n")
    refused("--export", "kalibr", foreign, fragments=["not a Kalibr imu.yaml", "cam0"])
    assert foreign.read_text() == "cam0:\n  intrinsics: [1, 2, 3, 4]\n"
    script = tmp_path / "mine.m"
    script.write_text("x = 1;\n")
    refused("--export", "matlab", script, fragments=["not written by bayescal"])
    assert script.read_text() == "x = 1;\n"
    assert sorted(path.name for path in tmp_path.iterdir()) == ["mine.m", "other.yaml"]


# --- What users have: text tables as loggers write them, arrays, MATLAB files -------------


@pytest.fixture(scope="module")
def plain(tmp_path_factory):
    """A 100 Hz gyro as a plain CSV, and its noise result: every other way of writing the same
    numbers must read back to this result."""
    folder = tmp_path_factory.mktemp("plain")
    rng = np.random.default_rng(11)
    time = np.arange(1500) / RATE
    gyro = 0.4 + 0.03 * rng.standard_normal(time.size)
    path = write_csv(folder / "plain.csv", {"time": time, "gyro_x": gyro})
    return {"folder": folder, "time": time, "gyro": gyro, "csv": path}


def _result(run_cli, path, tmp_path, *arguments):
    result, stdout = _noise_json(run_cli, path, tmp_path, "--channel", "gyro_x", *arguments)
    return _without_source(result), stdout


def _lines(time, gyro, delimiter=","):
    return [f"{t:.17g}{delimiter}{g:.17g}" for t, g in zip(time, gyro, strict=True)]


@pytest.mark.parametrize(
    ("name", "kind"),
    [
        ("semicolon.csv", "semicolon"),
        ("tab.tsv", "tab"),
        ("aligned.txt", "spaces"),
        ("comma_decimal.csv", "decimal comma"),
        ("comments.csv", "comments"),
        ("crlf_bom.csv", "crlf and bom"),
    ],
)
def test_text_layouts_read_as_the_plain_csv(run_cli, tmp_path, plain, name, kind):
    time, gyro = plain["time"], plain["gyro"]
    path = tmp_path / name
    if kind == "semicolon":
        path.write_text("\n".join(["time;gyro_x", *_lines(time, gyro, ";")]) + "\n")
    elif kind == "tab":
        path.write_text("\n".join(["time\tgyro_x", *_lines(time, gyro, "\t")]) + "\n")
    elif kind == "spaces":
        rows = [f"  {t:>24.17g}   {g:>24.17g}" for t, g in zip(time, gyro, strict=True)]
        path.write_text("\n".join(["   time        gyro_x", *rows]) + "\n")
    elif kind == "decimal comma":
        rows = [f"{t:.17g};{g:.17g}".replace(".", ",") for t, g in zip(time, gyro, strict=True)]
        path.write_text("\n".join(["time;gyro_x", *rows]) + "\n")
    elif kind == "comments":
        rows = _lines(time, gyro)
        path.write_text("\n".join(["# logger 1.2", "# serial 7", "", "time,gyro_x", *rows]) + "\n")
    else:
        text = "\r\n".join(["time,gyro_x", *_lines(time, gyro)]) + "\r\n"
        path.write_bytes(b"\xef\xbb\xbf" + text.encode())
    expected, _ = _result(run_cli, plain["csv"], tmp_path)
    found, _ = _result(run_cli, path, tmp_path)
    assert found == expected


def test_latin1_header_iso_stamps_and_times_of_day(run_cli, tmp_path, plain):
    time, gyro = plain["time"], plain["gyro"]
    expected, _ = _result(run_cli, plain["csv"], tmp_path)
    latin = tmp_path / "latin.csv"
    body = "\n".join(["time,gyro_x[°/s]", *_lines(time, gyro)]) + "\n"
    latin.write_bytes(body.encode("latin-1"))
    found, stdout = _result(run_cli, latin, tmp_path)
    assert "not UTF-8; read as Latin-1" in stdout and found["unit"] == "deg/s"

    start = np.datetime64("2024-05-01T23:59:50")
    stamps = start + np.round(time * 1e6).astype("timedelta64[us]")
    iso = tmp_path / "iso.csv"
    iso.write_text(
        "\n".join(["time,gyro_x", *(f"{s},{g:.17g}" for s, g in zip(stamps, gyro, strict=True))])
        + "\n"
    )
    found, stdout = _result(run_cli, iso, tmp_path)
    assert "read as dates and times" in stdout
    assert found["rate_hz"] == expected["rate_hz"] and found["n_samples"] == time.size
    assert found["classical"]["bias"] == expected["classical"]["bias"]

    clock = tmp_path / "clock.csv"  # times of day that pass midnight
    days = [str(s).split("T")[1] for s in stamps]
    clock.write_text(
        "\n".join(["t,gyro_x", *(f"{d},{g:.17g}" for d, g in zip(days, gyro, strict=True))])
    )
    found, stdout = _result(run_cli, clock, tmp_path)
    assert "read as times of day" in stdout and found["rate_hz"] == RATE


def test_logger_preamble_needs_skip_rows(run_cli, tmp_path, plain):
    path = tmp_path / "logger.csv"
    rows = _lines(plain["time"], plain["gyro"])
    path.write_text("\n".join(["Logger v1.2", "serial 0042", "time,gyro_x", *rows]) + "\n")
    code, stdout, stderr = run_cli("noise", path, "--channel", "gyro_x", "--classical-only")
    assert code == 2 and stdout == ""
    assert "the first 2 line(s)" in stderr and "'Logger v1.2'" in stderr
    assert "pass --skip-rows 2" in stderr
    expected, _ = _result(run_cli, plain["csv"], tmp_path)
    found, _ = _result(run_cli, path, tmp_path, "--skip-rows", "2")
    assert found == expected


def test_headerless_table_named_by_names(run_cli, tmp_path, plain):
    path = tmp_path / "bare.csv"
    path.write_text("\n".join(_lines(plain["time"], plain["gyro"])) + "\n")
    code, _, stderr = run_cli("noise", path, "--channel", "gyro_x", "--classical-only")
    assert code == 2 and "columns are: column_0, column_1" in stderr
    expected, _ = _result(run_cli, plain["csv"], tmp_path)
    found, _ = _result(run_cli, path, tmp_path, "--names", "time,gyro_x")
    assert found == expected
    code, _, stderr = run_cli("noise", path, "--names", "a,b,c", "--channel", "a")
    assert code == 2 and "--names gives 3 name(s) for a table of 2 columns" in stderr


def test_placeholder_first_row_of_zeros_is_left_out(run_cli, tmp_path, plain):
    time, gyro = plain["time"], plain["gyro"]
    path = write_csv(
        tmp_path / "zeros.csv",
        {"time": np.concatenate(([0.0], time + 5.0)), "gyro_x": np.concatenate(([0.0], gyro))},
    )
    expected, _ = _result(run_cli, plain["csv"], tmp_path)
    found, stdout = _result(run_cli, path, tmp_path)
    assert "data row 1 holds 0 in every sensor column" in stdout and "left out" in stdout
    assert found["classical"] == expected["classical"]
    # Row numbers in messages still count the file's rows.
    broken = gyro.copy()
    broken[99] = np.nan
    path = write_csv(
        tmp_path / "zeros_nan.csv",
        {"time": np.concatenate(([0.0], time + 5.0)), "gyro_x": np.concatenate(([0.0], broken))},
    )
    code, _, stderr = run_cli("noise", path, "--channel", "gyro_x", "--classical-only")
    assert code == 2 and "data row 101" in stderr


def test_npy_and_nd_npz_with_chosen_axes(run_cli, tmp_path, plain):
    time, gyro = plain["time"], plain["gyro"]
    expected, _ = _result(run_cli, plain["csv"], tmp_path)
    table = np.column_stack([time, gyro, 2 * gyro])
    np.save(tmp_path / "imu.npy", table)
    found, _ = _result(run_cli, tmp_path / "imu.npy", tmp_path, "--names", "time,gyro_x,other")
    assert found == expected
    code, _, stderr = run_cli(
        "noise", tmp_path / "imu.npy", "--channel", "imu_1", "--rate", "100", "--classical-only"
    )
    assert code == 0, stderr

    # recordings x axes x samples, as a study keeps several runs of a 3-axis gyro.
    runs = np.stack([np.stack([gyro + k, gyro - k, gyro * (k + 1)]) for k in range(3)])
    np.savez(tmp_path / "runs.npz", data=runs, rate=np.float64(100.0))
    names = ["--names", "gyro_x,gyro_y,gyro_z", "--rate", "100"]
    code, _, stderr = run_cli("noise", tmp_path / "runs.npz", *names, "--channel", "gyro_x")
    assert code == 2 and "gyro_x_rec0" in stderr  # the columns the array gives
    found, _ = _noise_json(
        run_cli, tmp_path / "runs.npz", tmp_path, *names, "--channel", "gyro_y_rec2"
    )
    assert found["classical"]["bias"]["value"] == pytest.approx(np.mean(gyro) - 2, rel=1e-12)
    # The same data stored samples x records x axes, axes named explicitly.
    np.savez(tmp_path / "moved.npz", data=np.moveaxis(runs, 2, 0))
    found, _ = _noise_json(
        run_cli,
        tmp_path / "moved.npz",
        tmp_path,
        "--samples-axis",
        "0",
        "--channels-axis",
        "2",
        *names,
        "--channel",
        "gyro_y_rec2",
    )
    assert found["classical"]["bias"]["value"] == pytest.approx(np.mean(gyro) - 2, rel=1e-12)
    square = np.zeros((40, 40))
    np.savez(tmp_path / "square.npz", data=square)
    code, _, stderr = run_cli("noise", tmp_path / "square.npz", "--channel", "data_0")
    assert code == 2 and "pass --samples-axis" in stderr


def test_mat_v5_struct_scalars_and_text(run_cli, tmp_path, plain):
    from scipy import io as scipy_io

    time, gyro = plain["time"], plain["gyro"]
    path = tmp_path / "session.mat"
    scipy_io.savemat(
        path,
        {
            "imu": {"t": time[:, None], "gyro": np.column_stack([gyro, -gyro])},
            "rate": 100.0,
            "operator": "A. N. Other",
            "rotation": np.eye(3),
        },
    )
    expected, _ = _result(run_cli, plain["csv"], tmp_path)
    found, _ = _result(
        run_cli,
        path,
        tmp_path,
        "--names",
        "imu.gyro:gyro_x,gyro_y",
        "--time-column",
        "imu.t",
        "--time-unit",
        "s",
    )
    assert found == expected
    for column, problem in (("rate", "is a single number"), ("operator", "holds text")):
        code, _, stderr = run_cli("noise", path, "--channel", column, "--rate", "100")
        assert code == 2 and problem in stderr, stderr
    code, _, stderr = run_cli("noise", path, "--channel", "rotation", "--rate", "100")
    assert code == 2 and "has at most 3 samples where the recording has 1500" in stderr


def test_mat_v73_mpu6050_real(run_cli, tmp_path, shared_data):
    """MATLAB v7.3 (HDF5) from sunsided/sensor-fusion: gyroBuffer is [t, x, y, z] x n in
    MATLAB's view; its stamps come in bursts, so the rate is given."""
    import h5py

    folder = shared_data / "sunsided_mpu6050/data/set-2/unmoved-with-x-pointing-forward"
    path = folder / "mpu6050_gyroscope.mat"
    with h5py.File(path) as handle:
        truth = handle["gyroBuffer"][()].T
    names = ["--names", "t,gyro_x[deg/s],gyro_y[deg/s],gyro_z[deg/s]"]
    code, _, stderr = run_cli("noise", path, *names, "--channel", "gyro_x", "--classical-only")
    assert code == 2 and "irregular sampling" in stderr and "their mean rate is 99." in stderr
    found, _ = _noise_json(run_cli, path, tmp_path, *names, "--channel", "gyro_x", "--rate", "99.3")
    assert found["n_samples"] == truth.shape[0] and found["unit"] == "deg/s"
    assert found["classical"]["bias"]["value"] == pytest.approx(truth[:, 1].mean(), rel=1e-12)
    assert found["classical"]["bias"]["value"] == pytest.approx(4.531, abs=0.01)  # SOURCE.txt


def test_text_mat_of_raw_counts_real(run_cli, tmp_path, shared_data):
    """imu_tk's xsens_gyro.mat is text (t and three ADC counts, no header): read as a table;
    counts taken for deg/s are refused, --scale makes them a rate."""
    path = shared_data / "imu_tk_xsens/xsens_gyro.mat"
    truth = np.loadtxt(path)
    quiet = ["--stop", "45", "--classical-only"]
    code, _, stderr = run_cli(
        "noise", path, "--names", "t,gyro_x,gyro_y,gyro_z", "--channel", "gyro_x", *quiet
    )
    assert code == 2 and "reads 327" in stderr and "raw counts?" in stderr
    assert "--scale" in stderr and "--unit LSB" in stderr
    names = ["--names", "t,gyro_x,gyro_y,gyro_z", "--channel", "gyro_x", *quiet]
    found, stdout = _noise_json(
        run_cli, path, tmp_path, *names, "--scale", "1/6258", "--unit", "rad/s"
    )
    window = truth[truth[:, 0] - truth[0, 0] < 45]
    assert found["classical"]["bias"]["value"] == pytest.approx(
        window[:, 1].mean() / 6258, rel=1e-9
    )
    assert "the .mat file is text" in stdout and "multiplied by 0.000159795" in stdout
    assert "counts with an offset" in stdout


def test_counts_npz_scaled_by_factor_or_sensor_card(run_cli, tmp_path, shared_data):
    """The ADIS16405 counts (int16) of the SMAC recordings: --scale 0.05 and the card's
    resolution give deg/s; the accelerometer's card resolution gives mg."""
    path = shared_data / "smac_imudata_adis16405/adis_16405_imu1-6_counts.npz"
    with np.load(path) as archive:
        counts = archive["imu1_counts"][:20_000].astype(float)
    small = tmp_path / "counts.npz"
    np.savez(small, imu1_counts=counts.astype(np.int16), fs_hz=np.float64(100))
    names = ["--names", "imu1_counts:gyro_x,gyro_y,gyro_z,acc_x,acc_y,acc_z", "--rate", "100"]
    by_factor, _ = _noise_json(
        run_cli,
        small,
        tmp_path,
        *names,
        "--channel",
        "gyro_y",
        "--scale",
        "0.05",
        "--unit",
        "deg/s",
    )
    by_card, _ = _noise_json(
        run_cli, small, tmp_path, *names, "--channel", "gyro_y", "--scale", "ADIS16405"
    )
    assert by_card["unit"] == "deg/s"
    assert by_card["classical"] == by_factor["classical"]
    assert by_factor["classical"]["bias"]["value"] == pytest.approx(
        0.05 * counts[:, 1].mean(), rel=1e-12
    )
    accel, _ = _noise_json(
        run_cli,
        small,
        tmp_path,
        *names,
        "--channel",
        "acc_z",
        "--scale",
        "ADIS16405",
        "--unit",
        "g",
    )
    assert accel["unit"] == "g"
    assert accel["classical"]["bias"]["value"] == pytest.approx(-1.016, abs=0.002)  # SOURCE.txt
    code, _, stderr = run_cli("noise", small, *names, "--channel", "gyro_y", "--scale", "nope")
    assert code == 2 and "no such sensor card" in stderr


def _kalibr_run(run_cli, path, channel, target, *extra):
    code, stdout, stderr = run_cli(
        "noise",
        path,
        "--channel",
        channel,
        "--classical-only",
        "--export",
        "kalibr",
        target,
        *extra,
    )
    assert code == 0, stderr
    return stdout


def test_kalibr_keeps_every_axis_of_a_sensor(run_cli, tmp_path, recordings):
    """gyro_x then gyro_z into one imu.yaml: one entry per sensor covering both, the largest
    (default) or the RMS of the axes, each axis kept in bayescal's notes; re-running an axis
    replaces it."""
    csv, imu_yaml = recordings["csv"], tmp_path / "imu.yaml"
    per_axis = {}
    for channel in ("gyro_x", "gyro_z"):
        result, _ = _noise_json(run_cli, csv, tmp_path, "--channel", channel)
        to_si = 1.0 if channel == "gyro_x" else np.pi / 180
        per_axis[channel] = {p: _classical_si(result, p, to_si) for p in ("N", "K")}
    _kalibr_run(run_cli, csv, "gyro_x", imu_yaml)
    stdout = _kalibr_run(run_cli, csv, "gyro_z", imu_yaml)
    assert "axes gyro_x kept beside gyro_z" in stdout
    imu = yaml.safe_load(imu_yaml.read_text())
    for parameter, key in (("N", "noise_density"), ("K", "random_walk")):
        largest = max(per_axis[c][parameter] for c in per_axis)
        assert imu[f"gyroscope_{key}"] == pytest.approx(largest, rel=1e-8)
    axes = imu["bayescal"]["gyroscope"]["axes"]
    assert (
        set(axes) == {"gyro_x", "gyro_z"} and imu["bayescal"]["gyroscope"]["combined"] == "largest"
    )
    assert "2 axes, each value below the largest of them" in imu_yaml.read_text()

    _kalibr_run(run_cli, csv, "gyro_x", imu_yaml, "--export-axes", "rms")
    imu = yaml.safe_load(imu_yaml.read_text())
    rms = np.sqrt(np.mean([per_axis[c]["N"] ** 2 for c in per_axis]))
    assert imu["gyroscope_noise_density"] == pytest.approx(rms, rel=1e-8)
    assert set(imu["bayescal"]["gyroscope"]["axes"]) == {"gyro_x", "gyro_z"}


def test_kalibr_export_waits_for_the_lock_and_reads_the_file_again(run_cli, tmp_path, recordings):
    """Two runs exporting to one imu.yaml take turns: a run waits for the lock beside the
    file, then reads the file as the other run left it (here, the accelerometer entries
    written while it waited) and adds its own."""
    import fcntl
    import threading

    csv, imu_yaml = recordings["csv"], tmp_path / "imu.yaml"
    _kalibr_run(run_cli, csv, "acc_y", tmp_path / "accel.yaml")
    finished = threading.Event()
    with open(tmp_path / ".imu.yaml.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        worker = threading.Thread(
            target=lambda: (_kalibr_run(run_cli, csv, "gyro_x", imu_yaml), finished.set())
        )
        worker.start()
        assert not finished.wait(3.0)  # blocked on the lock
        imu_yaml.write_text((tmp_path / "accel.yaml").read_text())  # the other run's output
    worker.join(60)
    assert finished.is_set()
    imu = yaml.safe_load(imu_yaml.read_text())
    assert "accelerometer_noise_density" in imu and "gyroscope_noise_density" in imu


def test_spreadsheet_and_logger_quirks(run_cli, tmp_path, plain):
    """Excel's sep=; line, UTF-16 text, a last line cut short by a logger (in UTF-8, UTF-16
    and Latin-1), a time column in hours: each reads as the plain CSV."""
    time, gyro = plain["time"], plain["gyro"]
    expected, _ = _result(run_cli, plain["csv"], tmp_path)
    rows = _lines(time, gyro, ";")
    excel = tmp_path / "excel.csv"
    excel.write_text("\n".join(["sep=;", "time;gyro_x", *rows]) + "\n")
    assert _result(run_cli, excel, tmp_path)[0] == expected
    unicode = tmp_path / "unicode.txt"
    unicode.write_bytes("\n".join(["time\tgyro_x", *_lines(time, gyro, "\t")]).encode("utf-16"))
    assert _result(run_cli, unicode, tmp_path)[0] == expected
    cut = tmp_path / "cut.csv"
    cut.write_text("\n".join(["time,gyro_x", *_lines(time, gyro), "15.0"]))
    found, stdout = _result(run_cli, cut, tmp_path)
    assert "the last line ('15.0') is cut short" in stdout
    assert found["classical"] == expected["classical"]
    for encoding in ("utf-16", "latin-1"):  # the stream ends before the cut line's bytes
        text = "\n".join(["# Gerät 1", "time,gyro_x", *_lines(time, gyro), "15.0"])
        cut.write_bytes(text.encode(encoding))
        found, stdout = _result(run_cli, cut, tmp_path)
        assert "the last line ('15.0') is cut short" in stdout
        assert found["classical"] == expected["classical"]
    hours = write_csv(tmp_path / "hours.csv", {"time[h]": time / 3600, "gyro_x": gyro})
    found, _ = _result(run_cli, hours, tmp_path)
    assert found["rate_hz"] == RATE and found["classical"] == expected["classical"]


def test_parquet_lists_of_numbers_read_as_one_column_per_element(run_cli, tmp_path, plain):
    """A Parquet column holding a vector per row (the three axes of a gyro, as some tools
    store them) reads as GYRO_0, GYRO_1, ... with the header's unit, like the channels of an
    array; lists of varying length and structs are refused with what to do, and the other
    columns of the file still read."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    time, gyro = plain["time"], plain["gyro"]
    expected, _ = _result(run_cli, plain["csv"], tmp_path)
    axes = [[-g, g, 2 * g] for g in gyro]
    path = tmp_path / "vectors.parquet"
    pq.write_table(
        pa.table(
            {
                "time": time,
                "gyro[deg/s]": axes,
                "fixed": pa.array(axes, type=pa.list_(pa.float64(), 3)),
                "ragged": [[1.0] * (1 + k % 2) for k in range(time.size)],
                "pose": [{"x": 1.0, "y": 2.0}] * time.size,
            }
        ),
        path,
    )
    found, _ = _noise_json(run_cli, path, tmp_path, "--channel", "gyro_1")
    assert found["unit"] == "deg/s"
    assert _without_source(found)["classical"] == expected["classical"]
    recording = bc.load_recording(path)
    assert np.array_equal(recording.columns["fixed_2"], 2 * gyro)
    for channel, fragments in [
        ("gyro", ["a list of 3 numbers per row", "gyro_0, gyro_1, gyro_2", "choose one of them"]),
        ("ragged", ["lists of 1 to 2 numbers per row", "its own column"]),
        ("pose", ["struct<x: double, y: double>", "column of numbers"]),
    ]:
        code, stdout, stderr = run_cli("noise", path, "--channel", channel, "--classical-only")
        assert code == 2 and stdout == "" and "\n" not in stderr.strip(), stderr
        for fragment in fragments:
            assert fragment in stderr, stderr
