"""Spectral lines: the periodogram test finds every line well above its detection limit (a
pair within three Fourier frequencies included), none on a clean record, each with its
frequency and amplitude inside their intervals; the noise fit's N is the floor between the
lines; a broadened line is told from a sinusoid and left out of the likelihood; a line in the
output filter's stop band is named aliased. Seeded; the study over many records is
benchmarks/noise_lines.py."""

import math

import numpy as np
import pytest
from scipy import signal, special

import bayescal as bc
from bayescal.classical._lines import (
    FULL_REACH,
    GUARD,
    SCALES,
    _Floors,
    _scale_dof,
    _scan,
    find_lines,
)
from bayescal.inference._lines_posterior import ALIAS_GAIN
from bayescal.models._noise_problem import record_components
from bayescal.models._whittle import spectral_summary

RATE = 100.0
SAMPLES = 2**14
NOISE = {"N": 0.01, "K": 2e-4, "F": 0.3}
# A strong line, a weak one (0.3 sample sd), and a pair 2.2 Fourier frequencies apart.
FREQUENCIES = (3.21, 17.5, 33.3, 33.3 + 2.2 * RATE / SAMPLES)
AMPLITUDES = (0.5, 0.03, 0.1, 0.06)


def _record(seed: int, lines: bool = True) -> np.ndarray:
    extra = {"line_frequency": FREQUENCIES, "line_amplitude": AMPLITUDES} if lines else {}
    return bc.NoiseModel(RATE, 0.2, **NOISE, **extra).simulate(SAMPLES, seed=seed)


@pytest.mark.parametrize("seed", [1, 2])
def test_every_line_is_found_with_its_frequency_and_amplitude(seed):
    search = find_lines(_record(seed), RATE)
    assert len(search.lines) == len(FREQUENCIES), search.lines
    for line, frequency, amplitude in zip(search.lines, FREQUENCIES, AMPLITUDES, strict=True):
        assert not line.broadened
        assert abs(line.frequency_hz - frequency) < 4 * line.frequency_sd_hz, line
        assert abs(line.amplitude - amplitude) < 4 * line.amplitude_sd, line


def test_no_line_on_clean_records():
    """Ten clean records (white, random walk, filter): the test, at a family-wise 0.1 %,
    calls nothing a line, and says what was strongest."""
    for seed in range(10):
        search = find_lines(_record(seed, lines=False), RATE)
        assert search.lines == ()
        assert search.largest["p_value"] > search.level
        assert "no line found" in search.verdict


def test_no_line_in_a_digital_filters_stop_band():
    """White noise through a fourth-order Butterworth at 0.3 of Nyquist, nothing added after
    it: near Nyquist its spectrum is 13 decades and more below the record's, below what the
    floors' cumulative sums resolve. Read as a floor of zero, every ordinate there was a line
    of infinite ratio (24 of them); an unresolved floor tests nothing."""
    numerator, denominator = signal.butter(4, 0.3)
    noise = np.random.default_rng(7).standard_normal(2**18)
    search = find_lines(0.05 * signal.lfilter(numerator, denominator, noise), RATE)
    assert search.lines == ()


def _every_window(power, usable, line_index, rho2, alpha):
    """The scan with every window's floor read (:meth:`_Floors.at`): per scale, the starts,
    ratios and log p-values of all windows, untested ones at 0."""
    floors, lowest, highest = _Floors(power, usable), 10, power.size - 2
    every = []
    for width in SCALES:
        starts = np.arange(lowest, highest - width + 2)
        sums = np.convolve(power, np.ones(width), mode="valid")[starts]
        centre = starts + (width - 1) / 2
        floor, count = floors.at(centre, np.full(starts.size, GUARD + (width - 1) / 2))
        good = count >= 4
        ratio = np.where(good, sums / (width * np.where(good, floor, 1.0)), 0.0)
        distance = np.min(np.abs(centre[:, None] - line_index[None, :]), axis=1)
        tested = good & (distance >= 0.5 * width)
        log_p = np.zeros(starts.size)
        with np.errstate(divide="ignore"):
            log_p[tested] = np.log(
                special.fdtrc(_scale_dof(width, rho2), 2 * count[tested], ratio[tested])
            )
        every.append((width, starts, ratio, log_p))
    return every


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("with_lines", [True, False])
def test_the_scan_reads_every_window_that_can_matter(seed, with_lines):
    """The scan reads the floors only of the windows its screen lets matter: the same
    windows significant, with the same p-values, and the same smallest p-value at a single
    ordinate (ratio and place), to the bit, as with every window's floor read — on spectra
    with lines (one whose p-value underflows) and without, unusable ordinates, a step in
    the floor, a stretch below the floors' resolution, and windows beyond the ordinate
    where the half-width stops growing."""
    rng = np.random.default_rng(seed)
    size = 4 * FULL_REACH
    power = rng.exponential(size=size) * np.linspace(1.0, 5.0, size)
    power[3 * FULL_REACH : 3 * FULL_REACH + 2000] *= 1e-17  # a stop band, not resolved
    power[2 * FULL_REACH + 100 :] *= 30.0  # a step in the floor: blocks whose bound is loose
    lines = np.array([700, 9000.0, 15000])
    if with_lines:
        power[lines.astype(int)] *= np.array([60.0, 1e6, 40.0])
        power[lines.astype(int)[2] + 2] *= 45.0  # a line beside a line found
    else:
        # The largest ordinate's floor holds a cluster its block's bound leaves out: its
        # ceiling is the highest, its ratio (25 / 1.3) below a lone one's (22 / 1).
        block = FULL_REACH + 32 * 40
        level = np.linspace(1.0, 5.0, size)
        power[block - GUARD : block + 31 - GUARD] = 6.0 * level[block]
        power[block + 31] = 25.0 * level[block + 31]
        power[block + 3000] = 22.0 * level[block + 3000]
    usable = rng.random(size) > 0.01
    usable[lines.astype(int)[:2]] = False
    rho2, alpha = 0.1, 1e-12
    scanned = _scan(power, usable, 10, size - 2, lines[:2], rho2, alpha)
    every = _every_window(power, usable, lines[:2], rho2, alpha)
    for (width, starts, ratio, log_p, significant), (_, all_starts, all_ratio, all_log_p) in zip(
        scanned, every, strict=True
    ):
        expected = all_log_p < math.log(alpha)
        assert expected.any() == (with_lines and width == 1) or width > 1
        np.testing.assert_array_equal(starts[significant], all_starts[expected])
        np.testing.assert_array_equal(log_p[significant], all_log_p[expected])
        np.testing.assert_array_equal(ratio[significant], all_ratio[expected])
        if width == 1:
            best, all_best = int(np.argmin(log_p)), int(np.argmin(all_log_p))
            assert starts[best] == all_starts[all_best]
            assert (ratio[best], log_p[best]) == (all_ratio[all_best], all_log_p[all_best])
        assert starts.size < all_starts.size / 10, (width, starts.size)


def test_a_record_too_short_is_not_searched():
    search = find_lines(np.random.default_rng(0).normal(size=40), RATE)
    assert search.lines == () and "shorter" in search.note


def test_the_noise_floor_between_the_lines():
    """With the lines the default model takes them out: N within 5 % of the truth and in its
    interval, the model fits, each line reported with an interval holding its amplitude;
    the term search's table says what the test found."""
    fit = bc.fit_noise(_record(3), RATE, unit="deg/s", seed=0)
    assert "spectral_lines" in fit.terms
    assert fit.passed, fit.failures
    n = fit.summary["N"]
    assert abs(n["mean"] / NOISE["N"] - 1) < 0.05 and n["q05"] < NOISE["N"] < n["q95"], n
    assert len(fit.lines.lines) == len(FREQUENCIES)
    for line, amplitude in zip(fit.lines.lines, AMPLITUDES, strict=True):
        assert line.amplitude["q05"] < amplitude < line.amplitude["q95"], line
    row = next(r for r in fit.selection.table if r["term"] == "spectral_lines")
    assert row["kept"] and "4 line(s)" in row["reason"]
    # Without the term the lines lift N: what the floor protects against.
    lifted = bc.fit_noise(_record(3), RATE, terms="white,rrw,output_filter", unit="deg/s")
    assert lifted.summary["N"]["mean"] > 1.1 * n["mean"]


def test_a_clean_record_leaves_the_term_out():
    fit = bc.fit_noise(_record(4, lines=False), RATE, unit="deg/s", seed=0)
    assert "spectral_lines" not in fit.terms and fit.lines is None
    row = next(r for r in fit.selection.table if r["term"] == "spectral_lines")
    assert not row["kept"] and "no line found" in row["reason"]


def test_a_broadened_line_is_its_power_and_width_and_is_left_out():
    """A line whose phase wanders (a fan's speed: a Lorentzian 0.04 Hz wide, six Fourier
    frequencies) is no sinusoid: it is reported broadened, with its band, and the
    likelihood leaves the band out."""
    rng = np.random.default_rng(5)
    t = np.arange(SAMPLES) / RATE
    phase = 2 * np.pi * 12.0 * t + np.cumsum(rng.normal(0, 0.05, SAMPLES))
    values = _record(6, lines=False) + 0.2 * np.sin(phase)
    search = find_lines(values, RATE)
    broad = [line for line in search.lines if line.broadened]
    assert len(broad) == 1, search.lines
    line = broad[0]
    assert line.band_hz[0] < 12.0 < line.band_hz[1] and line.width_hz > 0
    # Power within its interval of the truth's mean square (0.2^2 / 2), to its sd.
    assert abs(line.power - 0.02) < 4 * line.power_sd
    components = record_components(("white",), RATE, SAMPLES)
    whole = spectral_summary(values, RATE, components=components)
    left = spectral_summary(values, RATE, components=components, exclude=search.excluded_bands_hz)
    assert left.count.sum() < whole.count.sum()
    assert np.all(left.count > 0)


def test_a_broadened_line_flattened_leaves_the_white_level():
    """A line sampled by a clock that wanders (discovery's time-stamp jitter) is broadened;
    the record with its band brought down to the floor (what the output filter is decided
    on) has the white noise's variance again (but for the line's wings beyond its band), a
    band power at the floor, and the spectrum outside the band untouched — so the line cannot
    lift the white level into a deficit near Nyquist that a filter would be named for."""
    rng = np.random.default_rng(8)
    t = np.arange(SAMPLES) / RATE
    white = 0.05 * rng.standard_normal(SAMPLES)
    clock = np.cumsum(rng.standard_normal(SAMPLES)) * 0.5 / 6.5 / np.sqrt(SAMPLES)
    values = white + 0.1 * np.sin(2 * np.pi * 6.5 * (t + clock))
    search = find_lines(values, RATE)
    assert [line.broadened for line in search.lines] == [True], search.lines
    flat = search.flattened(values)
    # What is left is the line's wings beyond its band (below twice the floor): a few %.
    assert abs(flat.var() - white.var()) < 0.05 * (values.var() - white.var())
    spectrum = np.abs(np.fft.rfft(flat - flat.mean())) ** 2
    before = np.abs(np.fft.rfft(values - values.mean())) ** 2
    frequency = np.fft.rfftfreq(SAMPLES, 1 / RATE)
    low, high = search.lines[0].band_hz
    inside = (frequency >= low) & (frequency <= high)
    floor = search.lines[0].floor * SAMPLES * RATE / 2
    assert abs(spectrum[inside].mean() / floor - 1) < 1e-9
    assert np.allclose(spectrum[~inside][1:], before[~inside][1:])


def test_a_line_in_the_filters_stop_band_is_named_aliased():
    """Behind a low-pass at 10 Hz, a strong line at 40 Hz cannot have passed it: aliased."""
    noise = bc.NoiseModel(
        RATE,
        N=0.01,
        filter_cutoff=8.0,
        filter_order=4.0,
        filter_warping=0.5,
        line_frequency=(5.0, 40.0),
        line_amplitude=(0.05, 0.05),
    )
    fit = bc.fit_noise(noise.simulate(SAMPLES, seed=7), RATE, unit="deg/s", seed=0)
    lines = {round(line.frequency_hz["mean"]): line for line in fit.lines.lines}
    assert set(lines) == {5, 40}
    assert not lines[5].aliased and lines[40].aliased
    assert lines[40].filter_gain < ALIAS_GAIN


def test_the_benchmark_in_small():
    """One record as benchmarks/noise_lines.py draws them: 16 lines of 0.2 to 5 sample sds
    (log-uniform), four of them 1.5 to 3 Fourier frequencies from another, over white noise,
    a rate random walk and the one-tap filter. Every line found (all are above the detection
    limit at this length) within two Fourier frequencies of its truth, none invented, none
    taken for a broadened line; N within 5 % of the truth and inside its 90 % interval; the
    posterior passed its checks and the model fits."""
    rng = np.random.default_rng(34)
    resolution = RATE / SAMPLES
    sd = NOISE["N"] * np.sqrt(RATE)
    frequencies = list(rng.uniform(0.5, 0.45 * RATE, 12))
    for anchor in frequencies[:4]:
        frequencies.append(anchor + rng.uniform(1.5, 3.0) * resolution * rng.choice([-1, 1]))
    gaps = np.diff(np.sort(frequencies))
    assert gaps.min() > 1.4 * resolution  # the draw is the benchmark's: no two closer
    amplitudes = sd * np.exp(rng.uniform(np.log(0.2), np.log(5.0), len(frequencies)))
    noise = bc.NoiseModel(
        RATE,
        **NOISE,
        line_frequency=tuple(frequencies),
        line_amplitude=tuple(amplitudes),
    )
    fit = bc.fit_noise(noise.simulate(SAMPLES, seed=34), RATE, unit="deg/s", seed=0)
    assert fit.passed, fit.failures
    found = np.array([line.frequency_hz["mean"] for line in fit.lines.lines])
    assert len(found) == len(frequencies)
    assert not any(line.broadened for line in fit.lines.lines)
    for frequency in frequencies:
        assert np.min(np.abs(found - frequency)) <= 2 * resolution, frequency
    n = fit.summary["N"]
    assert abs(n["mean"] / NOISE["N"] - 1) < 0.05 and n["q05"] < NOISE["N"] < n["q95"], n
