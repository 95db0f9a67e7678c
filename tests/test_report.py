"""``bayescal report`` and ``bayescal demo``: the self-contained page, the JSON and netCDF
behind it, the discovery section, and the page in a real browser (headless chromium)."""

import base64
import io
import json
import re

import numpy as np
import pytest
import xarray as xr
from browser import chromium, followed, rendered, run_browser

import bayescal as bc

RATE_HZ = 10.0
N_SAMPLES = 2**13
GYRO_K = 1e-3  # deg/s*sqrt(Hz), the gyro's rate random walk
THERMAL_SLOPE = 0.02  # deg/s/degC, the gyro's bias against its die temperature
IMAGE = re.compile(r'<img[^>]*src="data:image/png;base64,([A-Za-z0-9+/=]+)"')


def _recording(path):
    """A short two-channel recording with its die temperature (warming 10 degC from power-on):
    a gyro (white noise, a random walk and a bias that follows the temperature) and an
    accelerometer at 1 g, both simulated by bayescal's own model."""
    import jax

    gyro = bc.NoiseModel(rate_hz=RATE_HZ, bias=0.2, N=0.02, K=GYRO_K)
    accel = bc.NoiseModel(rate_hz=RATE_HZ, bias=9.81, N=0.004, K=2e-4)
    keys = jax.random.split(jax.random.PRNGKey(5), 2)
    time = np.arange(N_SAMPLES) / RATE_HZ
    temperature = 25 + 10 * (1 - np.exp(-time / 150))
    columns = {
        "time": time,
        "gyro_x[deg/s]": np.asarray(gyro.sample(keys[0], N_SAMPLES))
        + THERMAL_SLOPE * (temperature - 25),
        "acc_z[m/s^2]": np.asarray(accel.sample(keys[1], N_SAMPLES)),
        "temperature[degC]": temperature,
    }
    lines = [",".join(columns)]
    lines += [",".join(repr(float(v)) for v in row) for row in zip(*columns.values(), strict=True)]
    path.write_text("\n".join(lines) + "\n")
    return path


def _nothing_found():
    """A real discovery where there is nothing to find: white noise alone (10 Hz, 410 s)."""
    from bayescal.report._discovery import Findings

    y = bc.NoiseModel(rate_hz=RATE_HZ, N=0.02).simulate(2**12, seed=3)
    found = bc.discover(y, RATE_HZ, unit="deg/s", channel="gyro_y", seed=1)
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
    """A report of the two channels, with a sensor card and discovery on the gyro."""
    from bayescal.report._discovery import discover_channel
    from bayescal.report._report import report_recording

    def discoveries(recording, channel):
        if channel.channel != "gyro_x":
            return None
        return discover_channel(recording, channel, seed=1)

    folder = tmp_path_factory.mktemp("report")
    outcome = report_recording(
        bc.load_recording(bench_csv),
        ["gyro_x", "acc_z"],
        folder / "out",
        stem="bench",
        sensor="MPU-6050",
        terms="white,rrw",
        seed=1,
        discoveries=discoveries,
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
    found = [effect["name"] for effect in document["discoveries"]["gyro_x"]["effects"]]
    assert "thermal_bias" in found
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
    empty = discovery_section(_nothing_found())
    assert "No effect found" in empty and "still fails" not in empty
    assert len(IMAGE.findall(empty)) == 3  # Allan, spectrum, residual: no temperature


def test_the_channel_tells_one_story_with_its_effect(report):
    """Discovery found the thermal bias the gyro's noise model (white, rrw) lacks: the
    summary, the JSON and the terminal show the noise of the model that holds it — its K and
    c1 hold the simulated ones, where the noise model without it read K too high — and mark
    the noise model's numbers as contaminated, linked to the discovery."""
    from bayescal.report._format import stacked
    from bayescal.report._report import summary_text

    outcome, _ = report
    gyro = next(analysis for analysis in outcome.analyses if analysis.channel == "gyro_x")
    assert gyro.effects.effects == ("thermal_bias",) and gyro.effects.passed
    document = json.loads(outcome.json.read_text())
    told = document["channels"]["gyro_x"]["with_effects"]
    k, c1 = told["parameters"]["K"], told["parameters"]["c1"]
    assert k["q05"] <= GYRO_K <= k["q95"], k
    assert c1["q05"] <= THERMAL_SLOPE <= c1["q95"], c1
    absorbed = document["channels"]["gyro_x"]["bayesian"]["parameters"]["K"]
    assert absorbed["q05"] > GYRO_K, absorbed  # the drift read as a random walk
    assert "with_effects" not in document["channels"]["acc_z"]
    page = outcome.html.read_text()
    summary = page[page.index("<h2>Summary</h2>") : page.index("<h2>Posterior health checks")]
    assert "href='#discovery-gyro_x'" in summary
    assert stacked(k["mean"], k["q05"], k["q95"], k["unit"]) in summary
    assert stacked(absorbed["mean"], absorbed["q05"], absorbed["q95"], k["unit"]) not in summary
    assert "contaminated" in page[page.index("<section id='channel-gyro_x'>") :]
    text = summary_text(outcome)
    assert "gyro_x   with thermal_bias:" in text and "discovery found thermal_bias" in text
    assert "contaminated" in text


def test_the_page_says_what_to_tell_a_navigation_filter(report):
    """The accelerometer's N and K as a filter's continuous densities, from its own noise fit
    (the posterior's 95 % quantile, m/s^2/sqrt(Hz)); the gyro, whose record holds the thermal
    bias its noise model lacks, withheld and why."""
    outcome, _ = report
    document = json.loads(outcome.json.read_text())["navigation_filter"]
    acc = next(a for a in outcome.analyses if a.channel == "acc_z").noise.noise
    n_draws = np.ravel(acc.draws["N"])
    assert document["values"]["accelerometer_noise_density"]["value"] == pytest.approx(
        float(np.quantile(n_draws, 0.95)), rel=1e-9
    )
    assert "gyroscope_noise_density" not in document["values"]
    assert "thermal_bias" in document["withheld"]["gyro_x"]
    page = outcome.html.read_text()
    section = page[page.index("<h2>For your navigation filter</h2>") :]
    assert "m/s^2/sqrt(Hz)" in section and "export-filter" in section


def test_discovery_figures_draw_the_bounds_of_their_checks(report):
    """A point of a discovery's Allan figure lies outside the band it is drawn in exactly
    when the Allan deviation check fails, before and after (the band is the check's own:
    Bonferroni-corrected over the taus)."""
    outcome, _ = report
    for findings in (outcome.findings["gyro_x"], _nothing_found()):
        allan = findings.curves.allan
        check = next(c for c in findings.discovery.checks if c.name == "allan_deviation")
        for measured, low, high, band_low, band_high, passed in (
            (
                allan.adev,
                allan.baseline_check_low,
                allan.baseline_check_high,
                allan.baseline_low,
                allan.baseline_high,
                check.passed_before,
            ),
            (
                allan.final_adev,
                allan.final_check_low,
                allan.final_check_high,
                allan.final_low,
                allan.final_high,
                check.passed_after,
            ),
        ):
            outside = (np.asarray(measured) < low) | (np.asarray(measured) > high)
            assert outside.any() == (not passed), (findings.channel, outside, passed)
            # The check's bounds hold the pointwise 90 % band: a point may leave the band
            # (one in ten does by chance) and still pass.
            assert np.all(low <= band_low) and np.all(band_high <= high)


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


def test_the_summary_links_to_the_discovery_section(report, tmp_path):
    """In a browser, the summary's link of the gyro, whose numbers come from the model with
    the effect discovery found, goes to that discovery: the page scrolls to its section."""
    outcome, _ = report
    went = followed(outcome.html, "a[href='#discovery-gyro_x']", tmp_path / "profile")
    assert went["hash"] == "#discovery-gyro_x" and went["target"] == "discovery-gyro_x", went
    assert 0 <= went["top"] < went["height"] and went["scrolled"] > 0, went


def test_demo_writes_the_page_and_tells_the_hidden_effects_story(run_cli, tmp_path):
    """The demo as a new user runs it (25 minutes, seed 0; benchmarks/demo_story.py runs its
    gyro_z over 50 seeds): discovery names the thermal bias hidden in gyro_z, the terminal
    says so, and the summary shows gyro_z's noise from the model that holds it, its K and c1
    holding the simulated ones (90 % intervals)."""
    out = tmp_path / "demo"
    code, stdout, stderr = run_cli("demo", "--out", out, "--quiet")
    assert code == 0, stderr
    page = out / "demo_imu_report.html"
    assert page.is_file() and f"report: {page}" in stdout
    assert (out / "demo_imu.csv").is_file() and (out / "demo_truth.json").is_file()
    header = (out / "demo_imu.csv").read_text().split("\n", 1)[0]
    for column in ("gyro_x[deg/s]", "gyro_z[deg/s]", "acc_z[m/s^2]", "temperature[degC]"):
        assert column in header
    truth = json.loads((out / "demo_truth.json").read_text())
    hidden = truth["hidden_effect"]
    assert hidden["name"] == "thermal_bias" and hidden["channel"] == "gyro_z"
    text = page.read_text()
    assert "Against the datasheet: MPU-6050" in text
    # Three figures per channel, and discovery's four per gyro (with the temperature).
    assert len(IMAGE.findall(text)) == 6 * 3 + 3 * 4
    document = json.loads((out / "demo_imu_report.json").read_text())
    acc_z = document["channels"]["acc_z"]["bayesian"]["parameters"]["bias"]
    assert acc_z["q05"] < 9.80665 + 0.09 < acc_z["q95"]
    # The story of the hidden-effect channel.
    assert "  gyro_z   with thermal_bias:" in stdout, stdout
    assert "discovery found thermal_bias" in stdout
    told = document["channels"]["gyro_z"]["with_effects"]
    k, c1 = told["parameters"]["K"], told["parameters"]["c1"]
    assert k["q05"] <= truth["channels"]["gyro_z"]["K"]["value"] <= k["q95"], k
    assert c1["q05"] <= hidden["c1"]["value"] <= c1["q95"], c1
    for channel in ("gyro_x", "gyro_y", "acc_x", "acc_y", "acc_z"):
        assert "with_effects" not in document["channels"][channel], channel
