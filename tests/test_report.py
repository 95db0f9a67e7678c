"""``bayescal report`` and ``bayescal demo``: the self-contained page, the JSON and netCDF
behind it, the discovery section, and the page in a real browser (headless chromium)."""

import base64
import io
import json
import re

import numpy as np
import pytest
import xarray as xr
from browser import chromium, rendered, run_browser

import bayescal as bc

RATE_HZ = 10.0
N_SAMPLES = 2**13
IMAGE = re.compile(r'<img[^>]*src="data:image/png;base64,([A-Za-z0-9+/=]+)"')


def _recording(path):
    """A short two-channel recording: a gyro (white noise and a random walk) and an
    accelerometer at 1 g, both simulated by bayescal's own model."""
    import jax

    gyro = bc.NoiseModel(rate_hz=RATE_HZ, bias=0.2, N=0.02, K=1e-3)
    accel = bc.NoiseModel(rate_hz=RATE_HZ, bias=9.81, N=0.004, K=2e-4)
    keys = jax.random.split(jax.random.PRNGKey(5), 2)
    columns = {
        "time": np.arange(N_SAMPLES) / RATE_HZ,
        "gyro_x[deg/s]": np.asarray(gyro.sample(keys[0], N_SAMPLES)),
        "acc_z[m/s^2]": np.asarray(accel.sample(keys[1], N_SAMPLES)),
    }
    lines = [",".join(columns)]
    lines += [",".join(repr(float(v)) for v in row) for row in zip(*columns.values(), strict=True)]
    path.write_text("\n".join(lines) + "\n")
    return path


def _findings(channel="gyro_x", *, thermal=True, samples=2**13):
    """A real discovery on a simulated record named ``channel`` (10 Hz): with ``thermal``, a
    bias that follows a warming die's temperature (0.004 deg/s/degC), found as
    thermal_bias; without, white noise alone, where nothing is found."""
    from bayescal.report._discovery import Findings

    time = np.arange(samples) / RATE_HZ
    temperature = 25 + 10 * (1 - np.exp(-time / 150)) if thermal else None
    y = bc.NoiseModel(rate_hz=RATE_HZ, N=0.02).simulate(samples, seed=2 if thermal else 3)
    if thermal:
        y = y + 0.004 * temperature
    found = bc.discover(y, RATE_HZ, temperature=temperature, unit="deg/s", channel=channel, seed=1)
    return Findings.of(found, source="simulated")


def _decoded_images(page: str) -> list[np.ndarray]:
    from matplotlib.image import imread

    found = IMAGE.findall(page)
    return [imread(io.BytesIO(base64.b64decode(data)), format="png") for data in found]


def _assert_not_blank(image: np.ndarray) -> None:
    assert image.ndim == 3 and image.shape[0] > 100 and image.shape[1] > 100
    gray = image[..., :3].mean(axis=-1)
    assert gray.std() > 0.03, "figure is (nearly) uniform"
    assert np.mean(gray < 0.9) > 0.01, "figure has almost nothing drawn on it"


@pytest.fixture(scope="module")
def bench_csv(tmp_path_factory):
    """The two-channel recording alone, for the tests that run the command on it (the report
    below is built once per worker process that asks for it)."""
    return _recording(tmp_path_factory.mktemp("bench") / "bench.csv")


@pytest.fixture(scope="module")
def report(tmp_path_factory, bench_csv):
    """A report of the two channels, with a sensor card and a hand-made discovery."""
    from bayescal.report._report import report_recording

    folder = tmp_path_factory.mktemp("report")
    outcome = report_recording(
        bc.load_recording(bench_csv),
        ["gyro_x", "acc_z"],
        folder / "out",
        stem="bench",
        sensor="MPU-6050",
        terms="white,rrw",
        seed=1,
        discoveries={"gyro_x": _findings()},
    )
    return outcome, bench_csv


def test_report_files_and_json(report):
    outcome, _ = report
    assert outcome.passed, [a.fit.diagnostics.failures for a in outcome.failed]
    folder = outcome.html.parent
    assert outcome.html.name == "bench_report.html" and outcome.html.stat().st_size > 50_000
    document = json.loads(outcome.json.read_text())
    assert document["schema"] == "bayescal.report" and document["passed"] is True
    assert set(document["channels"]) == {"gyro_x", "acc_z"}
    gyro = document["channels"]["gyro_x"]
    assert gyro["unit"] == "deg/s" and set(gyro["bayesian"]["parameters"]) == {"bias", "N", "K"}
    assert gyro["figures"]["allan"]["unit"] == "deg/s"
    assert gyro["datasheet"]["card"] == "MPU-6050"
    assert document["channels"]["acc_z"]["datasheet"]["parameters"]["N"]["unit"] == (
        "m/s^2/sqrt(Hz)"
    )
    assert document["discoveries"]["gyro_x"]["effects"][0]["name"] == "thermal_bias"
    assert set(document["discoveries"]["gyro_x"]["diagnostics"]) == {
        "allan",
        "spectrum",
        "residual",
        "temperature",
    }
    for channel in ("gyro_x", "acc_z"):
        path = folder / f"bench_{channel}_posterior.nc"
        tree = xr.open_datatree(path, engine="h5netcdf")
        assert "posterior" in tree.children
        mean = float(tree["posterior"]["N"].mean())
        assert mean == pytest.approx(
            document["channels"][channel]["bayesian"]["parameters"]["N"]["mean"], rel=1e-9
        )


def test_page_content_and_units(report):
    outcome, _ = report
    page = outcome.html.read_text()
    assert page.startswith("<!DOCTYPE html>") and page.rstrip().endswith("</html>")
    # Self-contained: no resource fetched from anywhere.
    assert not re.search(r'(src|href)="(https?:|//)', page)
    for text in (
        "Summary",
        "Posterior health checks",
        "Student-t interval of the bias",
        "deg/s/√Hz",
        "m/s²/√Hz",
        "deg/√h",
        "Against the datasheet: MPU-6050",
        "Discovery: gyro_x",
        "thermal_bias",
        "&nbsp;nats",
        "deg/s/°C",
        'id="discovery-gyro_x"',
    ):
        assert text in page, text
    assert "HEALTH CHECK FAILED" not in page
    # 3 figures per channel, and discovery's 4 (Allan and spectrum before and after, the
    # residual over time and against the temperature).
    images = _decoded_images(page)
    assert len(images) == 2 * 3 + 4
    for image in images:
        _assert_not_blank(image)


def test_posterior_bands_agree_with_the_data(report):
    """The predictive band of the Allan deviation covers most measured points, and the model
    spectrum's white level reads N."""
    outcome, _ = report
    for analysis in outcome.analyses:
        band = analysis.allan
        allan = analysis.noise.classical.allan
        measured = np.asarray(allan.deviation)[np.isfinite(allan.deviation)]
        inside = (band.predictive_low <= measured) & (measured <= band.predictive_high)
        assert inside.mean() >= 0.7, (analysis.channel, inside)
        assert np.all(band.expected_low <= band.expected_high)
        spectrum = analysis.spectrum
        high = spectrum.frequency_hz > 1.0
        n_mean = analysis.fit.parameters["N"].mean
        assert np.median(spectrum.expected_median[high]) == pytest.approx(n_mean, rel=0.05)
        assert np.median(spectrum.measured_asd[high]) == pytest.approx(n_mean, rel=0.1)


def test_discovery_section_alone(report):
    """A channel's discovery: the effect found with its parameters and the checks it answers,
    the figures before and after; where nothing was found, the baseline's figures alone."""
    from bayescal.report._html import discovery_section

    outcome, _ = report
    section = discovery_section(outcome.findings["gyro_x"])
    assert "thermal_bias" in section and "passes" in section and "deg/s/°C" in section
    images = _decoded_images(section)
    assert len(images) == 4
    for image in images:
        _assert_not_blank(image)
    empty = discovery_section(_findings("gyro_y", thermal=False, samples=2**12))
    assert "No effect found" in empty and "still fails" not in empty
    assert len(IMAGE.findall(empty)) == 3  # Allan, spectrum, residual: no temperature


def test_no_figure_changes_matplotlib_state(report):
    """Every figure is drawn on its own canvas: matplotlib's backend and pyplot's figures are
    as the user left them (a notebook's inline backend stays)."""
    import matplotlib

    from bayescal.report._figures import discovery_allan_figure, png

    outcome, _ = report
    backend = matplotlib.get_backend()
    findings = outcome.findings["gyro_x"]
    figure = discovery_allan_figure("gyro_x", "deg/s", findings.curves.allan, True)
    assert png(figure).startswith(b"\x89PNG")
    assert matplotlib.get_backend() == backend
    pyplot = __import__("sys").modules.get("matplotlib.pyplot")
    assert pyplot is None or pyplot.get_fignums() == []


def test_report_command_line(run_cli, bench_csv, tmp_path):
    out = tmp_path / "cli"
    code, stdout, stderr = run_cli(
        "report", bench_csv, "--channels", "gyro_x", "--out", out, "--terms", "white,rrw",
        "--sensor", "MPU-6050", "--quiet",
    )  # fmt: skip
    assert code == 0, stderr
    assert (out / "bench_report.html").is_file() and (out / "bench_report.json").is_file()
    assert (out / "bench_gyro_x_posterior.nc").is_file()
    assert f"report: {out / 'bench_report.html'}" in stdout and "gyro_x" in stdout
    assert "channel/s" not in stderr  # no progress bar when stderr is not a terminal


def test_report_failed_health_check_is_loud(run_cli, bench_csv, tmp_path):
    out = tmp_path / "failed"
    code, _, stderr = run_cli(
        "report", bench_csv, "--channels", "gyro_x", "--out", out, "--terms", "white,rrw",
        "--sensor", "MPU-6050", "--max-steps", "250",
    )  # fmt: skip
    assert code == 1 and "HEALTH CHECK FAILED" in stderr
    page = (out / "bench_report.html").read_text()
    assert "HEALTH CHECK FAILED" in page and "POSTERIOR CHECKS FAILED" in page
    assert "autocorrelation-time criterion not met" in page


def test_report_bad_input_exit_2(run_cli, bench_csv, tmp_path):
    code, _, stderr = run_cli("report", bench_csv, "--channels", "gyro_q", "--out", tmp_path / "x")
    assert code == 2 and "gyro_q" in stderr
    code, _, stderr = run_cli(
        "report", bench_csv, "--channels", "gyro_x", "--sensor", "nope", "--out", tmp_path / "y"
    )
    assert code == 2 and "no such sensor card" in stderr


def test_page_renders_in_a_browser(report, tmp_path):
    from matplotlib.image import imread

    outcome, _ = report
    page = outcome.html.read_text()
    dom, decoded, total = rendered(outcome.html, tmp_path / "profile")
    assert total == len(IMAGE.findall(page)) and total > 0
    assert decoded == total, f"only {decoded} of {total} figures decoded in the browser"
    assert "Posterior health checks" in dom

    screenshot = tmp_path / "page.png"
    result = run_browser(
        chromium(), tmp_path / "profile", f"--screenshot={screenshot}", "--window-size=1280,2000",
        outcome.html.as_uri(),
    )  # fmt: skip
    assert result.returncode == 0 and screenshot.is_file(), result.stderr[-2000:]
    _assert_not_blank(imread(screenshot))


def test_demo_writes_the_page(run_cli, tmp_path):
    """The demo's whole chain (shortened recording: the default 25 minutes is the same code
    with more samples)."""
    out = tmp_path / "demo"
    code, stdout, stderr = run_cli("demo", "--out", out, "--minutes", "5", "--quiet")
    assert code == 0, stderr
    page = out / "demo_imu_report.html"
    assert page.is_file() and f"report: {page}" in stdout
    assert (out / "demo_imu.csv").is_file() and (out / "demo_truth.json").is_file()
    header = (out / "demo_imu.csv").read_text().split("\n", 1)[0]
    for column in ("gyro_x[deg/s]", "gyro_z[deg/s]", "acc_z[m/s^2]", "temperature[degC]"):
        assert column in header
    truth = json.loads((out / "demo_truth.json").read_text())
    assert truth["hidden_effect"]["name"] == "thermal_bias"
    text = page.read_text()
    assert "Against the datasheet: MPU-6050" in text
    # Three figures per channel, and discovery's four per gyro (with the temperature).
    assert len(IMAGE.findall(text)) == 6 * 3 + 3 * 4
    document = json.loads((out / "demo_imu_report.json").read_text())
    acc_z = document["channels"]["acc_z"]["bayesian"]["parameters"]["bias"]
    assert acc_z["q05"] < 9.80665 + 0.09 < acc_z["q95"]
