"""Multi-position accelerometer calibration: recovery of simulated calibrations (free poses and
six faces), the classical fit against an independent least-squares solver, the two real
sessions against their published values (imu_tk's Xsens MTi, imucal's Ferraris session), the
command line's JSON, and bad input."""

import csv
import dataclasses
import json
import warnings
from pathlib import Path

import numpy as np
import pytest
from recording_files import write_csv
from scipy import stats
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

import bayescal as bc
from bayescal.classical._multi_position import (
    FREE_PARAMETERS,
    SIX_FACE_PARAMETERS,
    calibration_matrices,
)
from bayescal.models._multi_position import simulate_poses

GRAVITY = bc.LocalGravity(9.80123, 1e-5, "test")
# An Xsens-like raw-count sensor: scales (m/s^2 per count), misalignment angles, offsets.
SCALES, ANGLES, OFFSETS = [1 / 415, 1 / 413, 1 / 418], [0.004, -0.007, 0.011], [33100, 33270, 32370]
FREE_TRUTH = np.array([*SCALES, *ANGLES, *OFFSETS], dtype=float)
SIX_FACE_TRUTH = np.array([*SCALES, *ANGLES, 0.02, -0.01, 0.015, *OFFSETS], dtype=float)
FACES = np.vstack([np.eye(3), -np.eye(3)])
# Every simulated free session holds this many poses, so that the compiled least squares, MAP
# and posterior of one test serve the others (JAX compiles once per number of poses).
N_FREE = 14
# The published sessions: ../shared/data beside the project (present in CI, so a missing
# folder fails these tests instead of skipping them).
SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def random_directions(rng, count):
    directions = rng.standard_normal((count, 3))
    return directions / np.linalg.norm(directions, axis=1, keepdims=True)


def check_recovery(poses, truth, names, orientations):
    # At 0.999 a correct interval misses one parameter in a thousand.
    calibration = bc.calibrate_multi_position(
        poses,
        gravity=GRAVITY,
        unit="LSB",
        orientations=orientations,
        confidence=0.999,
        seed=1,
    )
    classical, fit = calibration.classical, calibration.bayesian
    assert classical.names == names
    for name, value, (estimate, half_width) in zip(
        names, truth, classical.parameters.values(), strict=True
    ):
        assert abs(estimate - value) <= half_width, name
    assert fit.diagnostics.passed, fit.diagnostics.failures
    standard_errors = np.sqrt(np.diag(classical.covariance))
    for name, value, standard_error in zip(names, truth, standard_errors, strict=True):
        draws = fit.draws[name]
        assert abs(draws.mean() - value) <= 4 * draws.std(), name
        # White noise only: both see the same information, except that the classical fit
        # estimates the noise from its few degrees of freedom (hence a factor of 2).
        assert 0.5 < draws.std() / standard_error < 2, name
    assert fit.draws["g_local"].std() == pytest.approx(GRAVITY.uncertainty, rel=0.1)
    return classical, fit


def test_free_poses_recover_scale_offset_and_misalignment():
    rng = np.random.default_rng(11)
    poses = simulate_poses(
        rng, FREE_TRUTH, random_directions(rng, N_FREE), GRAVITY.value, noise_sd=3.3
    )
    classical, fit = check_recovery(poses, FREE_TRUTH, FREE_PARAMETERS, "free")
    assert classical.dof == N_FREE - 9
    # The pose means carry only white noise, which the model already knows: the posterior of
    # the extra scatter sits below the noise of one pose mean (m/s^2).
    noise_of_a_mean = 3.3 / np.sqrt(200) * np.mean(SCALES)
    assert np.quantile(fit.draws["pose_scatter"], 0.5) < noise_of_a_mean


def test_six_faces_recover_the_full_matrix_and_mounting_rotation():
    rng = np.random.default_rng(12)
    poses = simulate_poses(rng, SIX_FACE_TRUTH, FACES, GRAVITY.value, six_face=True, noise_sd=3.3)
    classical, _ = check_recovery(poses, SIX_FACE_TRUTH, SIX_FACE_PARAMETERS, "six-face")
    assert classical.face_labels == ("+x", "+y", "+z", "-x", "-y", "-z")
    assert classical.dof == 6
    # Independently: Ferraris' model m_i = M f_i + b is linear; ordinary least squares per axis
    # gives the same M and b, and, b being a parameter of both, the same offset intervals.
    design = np.column_stack([GRAVITY.value * FACES, np.ones(6)])
    coefficients, rss, *_ = np.linalg.lstsq(design, poses.mean, rcond=None)
    matrices = calibration_matrices(classical.values, six_face=True)
    np.testing.assert_allclose(matrices["sensitivity_fixture"], coefficients[:3].T, rtol=1e-8)
    np.testing.assert_allclose(classical.values[-3:], coefficients[3], rtol=0, atol=1e-6)
    variance = rss.sum() / (3 * 6 - 12) * np.linalg.inv(design.T @ design)[3, 3]
    half_width = stats.t.ppf(0.9995, 6) * np.sqrt(variance)
    np.testing.assert_allclose(classical.uncertainty[-3:], half_width, rtol=1e-6)


def test_classical_fit_matches_an_independent_least_squares_solver():
    rng = np.random.default_rng(13)
    poses = simulate_poses(
        rng, FREE_TRUTH, random_directions(rng, N_FREE), GRAVITY.value, noise_sd=3.3
    )
    ours = bc.calibrate_multi_position(poses, gravity=GRAVITY, unit="LSB", bayesian=False).classical

    def residuals(p):  # imu_tk's residual, written out again
        k, (a_yz, a_zy, a_zx), b = p[:3] * 1e-3, p[3:6], p[6:]
        t = np.array([[1, -a_yz, a_zy], [0, 1, -a_zx], [0, 0, 1]])
        return np.linalg.norm((poses.mean - b) @ (t * k).T, axis=1) - GRAVITY.value

    start = np.concatenate([np.full(3, 1e3 / 415), np.zeros(3), poses.mean.mean(axis=0)])
    reference = least_squares(residuals, start, method="lm", xtol=1e-15, ftol=1e-15)
    values = reference.x * np.r_[np.full(3, 1e-3), np.ones(6)]
    jacobian = reference.jac / np.r_[np.full(3, 1e-3), np.ones(6)]
    covariance = (
        reference.fun @ reference.fun / (poses.n - 9) * np.linalg.inv(jacobian.T @ jacobian)
    )
    np.testing.assert_allclose(ours.values, values, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(ours.covariance, covariance, rtol=1e-4, atol=1e-20)


def test_poses_that_do_not_span_the_sphere_are_refused():
    rng = np.random.default_rng(14)
    directions = random_directions(rng, 200)
    cap = directions[directions[:, 2] > np.cos(np.radians(30))][:N_FREE]
    poses = simulate_poses(rng, FREE_TRUTH, cap, GRAVITY.value, noise_sd=3.3)
    with pytest.raises(bc.InputError, match="do not determine the calibration"):
        bc.calibrate_multi_position(poses, gravity=GRAVITY, unit="LSB", bayesian=False)
    five_faces = simulate_poses(
        rng, SIX_FACE_TRUTH, np.vstack([FACES[:5]] * 2), GRAVITY.value, six_face=True, noise_sd=3.3
    )
    with pytest.raises(bc.InputError, match="not -z"):
        bc.calibrate_multi_position(
            five_faces, gravity=GRAVITY, unit="LSB", orientations="six-face", bayesian=False
        )


# --- real sessions --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def shared_data():
    assert SHARED_DATA.is_dir(), f"the published sessions are missing: no folder {SHARED_DATA}"
    return SHARED_DATA


def pair_angles(sensitivity):
    """Cosines between the sensing axes (rows), x-y, x-z, y-z: the non-orthogonality, which
    no choice of reference frame changes."""
    rows = sensitivity / np.linalg.norm(sensitivity, axis=1, keepdims=True)
    gram = rows @ rows.T
    return np.array([gram[0, 1], gram[0, 2], gram[1, 2]])


def test_xsens_session_agrees_with_the_datasheet(shared_data):
    """imu_tk's own test session: raw counts of an Xsens MTi, 41 still poses at 100 Hz (the
    Bayesian fit on 12 of them, a hand-held session of the size people record), with
    the values the imu_tk authors took from the datasheet (SOURCE.txt), at imu_tk's gravity.
    The datasheet is a factory calibration of another day and temperature, printed as
    integers and two decimals: the tolerances below are that rounding and the sensor's
    repeatability, far wider than our intervals (0.01-0.04 % on the scales)."""
    data = np.loadtxt(shared_data / "imu_tk_xsens" / "xsens_acc.mat")
    assert np.median(np.diff(data[:, 0])) == pytest.approx(0.01, abs=1e-4)
    gravity = bc.LocalGravity(9.81744, 0.0, "imu_tk's test application")
    calibration = bc.calibrate_multi_position(
        data[:, 1:], 100.0, gravity=gravity, unit="LSB", bayesian=False
    )
    assert calibration.poses.n == 41
    classical = calibration.classical
    # The Bayesian fit on a hand-held session of 12 poses (the third to the fourteenth, in 9
    # orientations): it converges and agrees with the datasheet as the 41 poses do.
    poses = calibration.poses
    session = bc.Poses(*(np.asarray(field)[2:14] for field in dataclasses.astuple(poses)))
    fit = bc.calibrate_multi_position(session, gravity=gravity, unit="LSB", seed=1).bayesian
    assert fit.diagnostics.passed, fit.diagnostics.failures
    datasheet_sensitivity = np.array([415, 413, 415])  # counts per m/s^2, integers
    datasheet_misalignment = np.array([[1, 0, -0.01], [0.01, 1, 0.01], [0.02, 0.01, 1]])
    offsets = np.array([33123, 33276, 32360])  # counts, from imu_tk_matlab's calibrate.m
    posterior_means = np.array([fit.draws[name].mean() for name in FREE_PARAMETERS])
    for values in (classical.values, posterior_means):
        # Scale: within 0.5 % (the datasheet's integers are rounded by up to 0.12 %, and its
        # factory calibration is of another day and temperature); found: 0.09-0.24 %.
        np.testing.assert_allclose(1 / values[:3], datasheet_sensitivity, rtol=5e-3)
        # Offsets: within 10 counts (2.4 mg; turn-on bias repeatability); found: 1-5 counts.
        np.testing.assert_allclose(values[6:], offsets, atol=10)
        # Non-orthogonality: the datasheet rounds each matrix entry to 0.01, so each cosine
        # between two of its axes (a sum of two entries) is known to +-0.01.
        sensitivity = calibration_matrices(values, six_face=False)["sensitivity"]
        np.testing.assert_allclose(
            pair_angles(sensitivity), pair_angles(datasheet_misalignment), atol=0.01
        )


def annotated_parts(shared_data):
    parts = {}
    with open(shared_data / "imucal_ferraris" / "annotated_session.csv") as handle:
        for row in csv.DictReader(handle):
            parts.setdefault(row["part"], []).append(
                [float(row[c]) for c in ("acc_x", "acc_y", "acc_z")]
            )
    return {name: np.array(values) for name, values in parts.items()}


def test_imucal_ferraris_session_agrees_with_imucal(shared_data):
    """imucal's regression snapshot: its Ferraris calibration (g = 9.81) of the annotated
    session in raw counts, a = R_a^-1 K_a^-1 (r - b_a)."""
    parts = annotated_parts(shared_data)
    order = ("x_p", "x_a", "y_p", "y_a", "z_p", "z_a")
    poses = bc.Poses.from_samples([parts[name] for name in order])
    classical = bc.calibrate_multi_position(
        poses,
        gravity=bc.LocalGravity(9.81, 0.0, "imucal's default"),
        orientations="six-face",
        unit="LSB",
        bayesian=False,
    ).classical
    reference = json.loads((shared_data / "imucal_ferraris" / "example_cal.json").read_text())
    k_a, r_a, b_a = (np.array(reference[key]) for key in ("K_a", "R_a", "b_a"))
    matrices = calibration_matrices(classical.values, six_face=True)
    # With one pose per face, least squares gives Ferraris' M = (U_p - U_n) / 2g exactly.
    np.testing.assert_allclose(matrices["sensitivity_fixture"], k_a @ r_a, rtol=1e-9)
    # imucal's scales are the row norms of M; ours (1/k) leave out the misalignment's share.
    np.testing.assert_allclose(1 / classical.values[:3], np.diag(k_a), rtol=2e-4)
    np.testing.assert_allclose(pair_angles(matrices["sensitivity_fixture"]), pair_angles(r_a))
    # Offsets: imucal takes each from its own axis' pair of faces, least squares from all six;
    # the difference (2-8 counts) is the poses' misfit, within our interval.
    ferraris = [(poses.mean[2 * j, j] + poses.mean[2 * j + 1, j]) / 2 for j in range(3)]
    np.testing.assert_allclose(ferraris, b_a, rtol=1e-12)
    offset, half_width = classical.values[-3:], classical.uncertainty[-3:]
    assert np.all(np.abs(offset - b_a) <= half_width)


@pytest.fixture(scope="module")
def ferraris_session(shared_data):
    folder = shared_data / "imucal_ferraris"
    listed = json.loads((folder / "example_ferraris_session_list.json").read_text())
    rate = 102.4  # imucal's examples/basic_ferraris.py
    sections = ",".join(
        f"{listed[name]['start'] / rate}:{listed[name]['end'] / rate}"
        for name in ("x_p", "x_a", "y_p", "y_a", "z_p", "z_a")
    )
    return folder, sections


def test_ferraris_session_command_line(run_cli, tmp_path, ferraris_session):
    """imucal's example session (m/s^2): six faces by imucal's own sections reproduce imucal's
    calibrated output (its test file) to within our offset interval; free orientations are
    refused, since its 13 still poses hold only 6 orientations."""
    folder, sections = ferraris_session
    session = folder / "example_ferraris_session.csv"
    common = [session, "--channels", "acc_x,acc_y,acc_z", "--rate", "102.4", "--g-local", "9.81"]
    output = tmp_path / "out.json"
    code, stdout, stderr = run_cli(
        "multi-position",
        *common,
        "--orientations",
        "six-face",
        "--sections",
        sections,
        "--classical-only",
        "--json",
        output,
    )
    assert code == 0, stderr
    result = json.loads(output.read_text())
    assert [pose["face"] for pose in result["poses"]["list"]] == [
        "+x",
        "-x",
        "+y",
        "-y",
        "+z",
        "-z",
    ]
    classical = result["classical"]
    sensitivity = np.array(classical["matrices"]["sensitivity_fixture"])
    offsets = np.array(classical["matrices"]["offset_b"])
    rows = np.loadtxt(session, delimiter=",", skiprows=1, max_rows=50)[:, 4:7]
    ours = np.linalg.solve(sensitivity, (rows - offsets).T).T
    imucal = np.loadtxt(folder / "ferraris_example.csv", delimiter=",", skiprows=1)[:, 4:7]
    half_width = classical["parameters"]["offset_x"]["uncertainty"]
    assert np.abs(ours - imucal).max() <= half_width
    assert "unit of 'acc_x' not given; assumed m/s^2" in stdout

    code, stdout, stderr = run_cli("multi-position", *common, "--classical-only")
    assert code == 2 and stdout == ""
    assert "13 still poses but only 6 distinct orientations" in stderr
    assert "--orientations six-face" in stderr


# --- the command line on a simulated session ------------------------------------------------


def write_session(path, directions, truth=FREE_TRUTH, rate=100.0, dwell_s=3.0, turn_s=1.0):
    """A recording in counts: each orientation held for ``dwell_s``, then a turn to the next
    over ``turn_s`` (the gravity direction swept along the great circle between them)."""
    rng = np.random.default_rng(5)
    directions = np.asarray(directions)
    path_points = []
    for here, there in zip(directions, np.vstack([directions[1:], directions[:1]]), strict=True):
        path_points.append(np.repeat(here[None], int(dwell_s * rate), axis=0))
        if np.allclose(here, there):
            continue
        sweep = Rotation.align_vectors(there[None], here[None])[0].as_rotvec()
        fractions = np.arange(1, int(turn_s * rate)) / (turn_s * rate)
        path_points.append(Rotation.from_rotvec(fractions[:, None] * sweep).apply(here))
    body = np.vstack(path_points)
    a_yz, a_zy, a_zx = truth[3:6]
    matrix = np.array([[1, -a_yz, a_zy], [0, 1, -a_zx], [0, 0, 1]]) * truth[:3]
    counts = np.linalg.solve(matrix, GRAVITY.value * body.T).T + truth[6:9]
    counts += 3.3 * rng.standard_normal(counts.shape)
    time = np.arange(counts.shape[0]) / rate
    x, y, z = counts.T
    columns = {"time": time, "acc_x[LSB]": x, "acc_y[LSB]": y, "acc_z[LSB]": z}
    return write_csv(path, columns, fmt="%.5f")


def test_command_line_json_contract(run_cli, tmp_path):
    rng = np.random.default_rng(15)
    directions = random_directions(rng, N_FREE)
    path = write_session(tmp_path / "session.csv", directions)
    output = tmp_path / "out.json"
    code, stdout, stderr = run_cli(
        "multi-position",
        path,
        "--channels",
        "acc_x,acc_y,acc_z",
        "--g-local",
        f"{GRAVITY.value}±{GRAVITY.uncertainty}",
        "--json",
        output,
        "--seed",
        "2",
    )
    assert code == 0, stderr
    result = json.loads(output.read_text())
    assert result["command"] == "multi-position" and result["unit"] == "LSB"
    assert result["poses"]["count"] == N_FREE
    for pose, start in zip(result["poses"]["list"], 4.0 * np.arange(N_FREE), strict=True):
        assert start <= pose["start_s"] < start + 1 and pose["stop_s"] <= start + 3.01
    classical = result["classical"]["parameters"]
    bayesian = result["bayesian"]["parameters"]
    assert list(classical) == list(FREE_PARAMETERS)
    assert set(bayesian) == {*FREE_PARAMETERS, "pose_scatter", "g_local"}
    units = {name: entry["unit"] for name, entry in bayesian.items()}
    assert units["scale_x"] == "m/s^2/LSB" and units["offset_z"] == "LSB"
    assert units["misalignment_zx"] == "rad" and units["pose_scatter"] == "m/s^2"
    assert units["g_local"] == "m/s^2"
    for name, entry in bayesian.items():
        assert set(entry) == {"mean", "sd", "q05", "q95", "map", "map_sd", "unit"}, name
        assert classical.get(name, {"unit": entry["unit"]})["unit"] == entry["unit"]
    for name, truth in zip(FREE_PARAMETERS, FREE_TRUTH, strict=True):
        assert abs(bayesian[name]["mean"] - truth) <= 4 * bayesian[name]["sd"], name
    diagnostics = result["bayesian"]["diagnostics"]
    assert diagnostics["passed"] and diagnostics["failures"] == []
    assert "posterior checks passed" in stdout and "misalignment_yz" in stdout


def assert_refused(run_cli, tmp_path, arguments, *fragments):
    output = tmp_path / "out.json"
    code, stdout, stderr = run_cli(
        "multi-position", *arguments, "--g-local", "9.80123", "--json", output
    )
    assert code == 2, stderr
    message = stderr.strip()
    assert "\n" not in message and "Traceback" not in message
    for fragment in fragments:
        assert fragment in message, message
    assert stdout == "" and not output.exists()


def test_bad_input(run_cli, tmp_path):
    rng = np.random.default_rng(16)
    channels = ["--channels", "acc_x,acc_y,acc_z"]
    few = write_session(tmp_path / "few.csv", random_directions(rng, 5))
    assert_refused(
        run_cli,
        tmp_path,
        [few, *channels],
        "few.csv",
        "found 5 still pose(s); the free model needs at least 10",
        "record more poses in different orientations",
    )
    # Turning all the time: the gravity direction sweeps a circle at 10 deg/s for 60 s.
    turning = write_session(
        tmp_path / "turning.csv",
        Rotation.from_rotvec(np.radians(np.arange(0, 360, 10))[:, None] * [0, 1, 0]).apply(
            [0, 0, 1]
        ),
        dwell_s=0.0,
    )
    assert_refused(run_cli, tmp_path, [turning, *channels], "turning.csv", "no still poses found")
    assert_refused(
        run_cli,
        tmp_path,
        [few, *channels, "--sections", "0:3,3.5:5"],
        "the section 3.5-5 s is not still: its y reading moves by 208.5 LSB",
        "--sections",
    )
    assert_refused(
        run_cli, tmp_path, [few, "--channels", "acc_x,acc_y,acc_q"], "no channel 'acc_q'"
    )
    assert_refused(
        run_cli,
        tmp_path,
        [few, *channels, "--unit", "deg/s"],
        "the unit deg/s is a unit of angular rate, not of acceleration",
        "--unit",
    )
    assert_refused(
        run_cli, tmp_path, [few, *channels, "--sections", "0-3"], "--sections", "START:STOP"
    )
    assert_refused(
        run_cli,
        tmp_path,
        [few, *channels, "--orientations", "six-face"],
        "found 5 still pose(s); a six-face calibration needs all six",
    )
    # One pose: its direction is its own mean (the centre of one pose is the pose), and no
    # numpy warning of a 0 / 0 reaches the user's terminal before the message.
    single = write_session(tmp_path / "single.csv", [[0.0, 0.0, 1.0]], dwell_s=5.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        assert_refused(run_cli, tmp_path, [single, *channels], "found 1 still pose(s)", "s (+z)")
    directions = random_directions(rng, 12)
    readings = np.repeat(directions, 300, axis=0) + 0.001 * rng.standard_normal((12 * 300, 3))
    x, y, z = readings.T
    columns = {"time": np.arange(12 * 300) / 100, "acc_x": x, "acc_y": y, "acc_z": z}
    in_g = write_csv(tmp_path / "in_g.csv", columns)
    assert_refused(
        run_cli,
        tmp_path,
        [in_g, *channels, "--unit", "m/s^2"],
        "read about 1 m/s^2 in magnitude",
        "the unit is probably g",
        "--unit g",
    )


def test_a_failed_health_check_exits_1(run_cli, tmp_path, monkeypatch):
    import bayescal.capabilities._multi_position as model
    from bayescal.inference._mcmc import Diagnostics

    def unhealthy(poses, classical, **_):
        names = (*classical.names, "pose_scatter", "g_local")
        values = [*classical.values, 1e-3, GRAVITY.value]
        failure = "R-hat of scale_x across walker groups is 1.200 (> 1.01)"
        diagnostics = Diagnostics(
            passed=False,
            failures=(failure,),
            converged=True,
            n_walkers=32,
            n_steps=500,
            burn_in=100,
            thin=10,
            autocorr_time=dict.fromkeys(names[:-1], 10.0),
            ess_bulk=dict.fromkeys(names[:-1], 1000.0),
            rhat={name: 1.2 if name == "scale_x" else 1.0 for name in names[:-1]},
            acceptance_fraction=0.3,
            min_walker_acceptance=0.2,
            map_converged=True,
        )
        draws = {name: np.full((32, 50), value) for name, value in zip(names, values, strict=True)}
        spread = dict.fromkeys(names, 0.0)
        return model.BayesianCalibration(
            names, draws, dict(zip(names, values, strict=True)), spread, diagnostics
        )

    monkeypatch.setattr(model, "bayesian_multi_position", unhealthy)
    directions = random_directions(np.random.default_rng(17), N_FREE)
    path = write_session(tmp_path / "session.csv", directions)
    output = tmp_path / "out.json"
    code, stdout, stderr = run_cli(
        "multi-position",
        path,
        "--channels",
        "acc_x,acc_y,acc_z",
        "--g-local",
        "9.80123",
        "--json",
        output,
    )
    assert code == 1
    assert "HEALTH CHECK FAILED" in stderr and "R-hat of scale_x" in stderr
    assert "posterior checks FAILED" in stdout
    assert json.loads(output.read_text())["bayesian"]["diagnostics"]["passed"] is False


def test_a_hand_held_session_too_short_for_the_minimum_lists_its_poses(run_cli, shared_data):
    """Poses held for less than --min-still: the error lists the poses found and offers the
    shorter minimum that finds enough (exit 2, nothing written)."""
    code, _, stderr = run_cli(
        "multi-position",
        shared_data / "imu_tk_xsens" / "xsens_acc.mat",
        "--channels", "x,y,z", "--names", "t,x,y,z", "--time-column", "t", "--unit", "LSB",
        "--g-local", "9.81744", "--classical-only", "--min-still", "9",
    )  # fmt: skip
    assert code == 2, stderr
    assert "found 9 still pose(s)" in stderr
    assert "93.1-102.4 s (+y)" in stderr
    assert "--min-still 1.5 finds 42 poses in 14 orientations" in stderr
