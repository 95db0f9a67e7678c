"""Spectral lines in a record: sinusoids (vibration, a fan, a converter's clock, mains) found
by a periodogram test corrected for the number of frequencies looked at, each with its
frequency, amplitude and their standard errors; a line whose power spreads beyond a sinusoid's
(a wandering fan) is a broadened line, with its power and width.

**The test.** On the tapered periodogram of the record's increments
(:mod:`._periodogram`), each ordinate I_j is set against the local floor: the mean of the
ordinates on either side of it (a window of 5 % of its frequency, 16 to 256 ordinates each
side) that lie beyond a guard of :data:`GUARD` ordinates (the taper's main lobe) and away
from lines already found. Under the null — a smooth spectrum, no line — I_j over its floor
is the ratio of an exponential to the mean of c exponentials: F(2, 2c), so that
P(ratio > x) = (1 + x / c)^-c, exact for the floor's own scatter. Broadened lines are looked
for the same way at sums of 4 and 16 neighbouring ordinates (F(2w', 2c), w' the sum's
degrees of freedom under the taper's correlation of neighbouring ordinates). The ordinates
from :data:`LOWEST_CYCLES` cycles per record to below Nyquist, at each scale, are M tests:
an ordinate is a line when its p-value is below 1 - (1 - level)^(1/M) (Šidák), so that a
record without lines shows one with probability ``level`` (:data:`LINE_LEVEL`, 0.1 %). A floor
too far below the record's power to be resolved (13 decades: a digital filter's stop band with
nothing added after it) tests nothing there.

**Estimates.** Found lines are fitted jointly by least squares to the increments (weighted by
the taper squared, a constant beside them): y_t = a sin(2 pi f t) + b cos(2 pi f t) per line
(t in seconds from the record's first sample), its increments the regressors; each line's
frequency is then refined by coordinate ascent (the maximum of the weighted transform of
the record less the other lines, Newton's method from a 1/8-ordinate grid), and the
amplitudes refitted. Lines are found in rounds (CLEAN, Högbom 1974): the strongest in each
neighbourhood of :data:`REACH` ordinates first, then what the record less them shows — so a
weaker line within a few ordinates of a strong one, or beside its sidelobes, is found next.

**Uncertainty.** With the increments' spectrum S locally flat around a line (over its few
ordinates), the covariance of every line's coefficients and frequency is S times the weighted
least-squares sandwich (J'WJ)^-1 J'W^2J (J'WJ)^-1 of the fitted increments' Jacobian J (W the
taper squared): for a lone sinusoid in white noise its frequency's variance is the
Cramér-Rao bound 6 S_y / (pi^2 A^2 n^3) (cycles per sample; S_y the samples' spectrum, Rife &
Boorstyn 1974) times the taper's loss, and a neighbour within a few ordinates widens it as
the joint Fisher information says.

**Broadened lines.** After the coherent fit, the record less the lines is tested again around
each line, beyond its main lobe: where the power left there is significant and at least a
fifth of the line's, the line is broadened — its sinusoid is not taken out, its band (where
the record holds at least twice the floor, contiguous with the peak) is reported with the
power in it (the sum of the periodogram's excess, sd from the ordinates' exponential
scatter) and its width (twice the rms spread of that excess about its centre), and a fit of
the noise leaves the band out.
"""

import dataclasses
import functools
import math
from dataclasses import dataclass, field

import numpy as np
from scipy import special

from ..recording._series import is_spooled
from ._periodogram import (
    TAPER_FRACTION,
    RecordTransform,
    fast_length_at_most,
    longest_run,
    tapered_transform,
    transform_power,
    tukey_energy,
    tukey_window,
)

LINE_LEVEL = 0.001
"""The probability that a record without lines shows one (family-wise, over every frequency
and scale looked at)."""
LOWEST_CYCLES = 10
"""Below this many cycles per record a line cannot be told from a slow wander: not tested."""
GUARD = 3
"""Ordinates each side of a tested one (and of a line found) left out of its floor: the
taper's main lobe and first sidelobes."""
FLOOR_FRACTION = 0.05
"""Half-width of an ordinate's floor window, as a fraction of its frequency ..."""
FLOOR_ORDINATES = (16, 256)
"""... at least and at most this many ordinates each side."""
SCALES = (1, 4, 16)
"""Sums of neighbouring ordinates tested: a sinusoid (1) and broadened lines (4, 16)."""
MIN_FLOOR_ORDINATES = 4
"""A floor averages at least this many ordinates, or its window is not tested."""
SCREEN_BLOCK = 32
"""Windows whose floors the scan bounds together (:meth:`_Floors.lower_bounds`)."""
REACH = 12
"""Within a round, a candidate must be the largest within this many ordinates: what lies
beside a strong line (its sidelobes, a weaker neighbour) waits for the record less it."""
MAX_LINES = 24
"""The most lines a record is searched for."""
MAX_ROUNDS = 8
RESIDUE = 1.5
"""A candidate this near a sinusoid found (ordinates) is fitted as a sinusoid even where only
a sum of ordinates is significant: a close neighbour, or what a broadened line leaves."""
RESOLVED = 1.0
"""Two sinusoids fitted closer than this (ordinates) are not told apart: a broadened line."""
COMB = 1.5
"""Three sinusoids or more each within this of the next (ordinates) are a broadened line."""
CLUSTER = 4.0
"""Sinusoids within this many ordinates of each other are refined jointly."""
BROAD_SHARE = 0.2
"""A line whose power left after its sinusoid is taken out is at least this share of its
power is broadened (module docstring)."""
MIN_SAMPLES = 64
"""Records (gap-free runs) shorter than this are not searched."""
_CHUNK = 1 << 16
"""Samples per block of the least-squares sums (bounds the memory of the regressors)."""


@dataclass(frozen=True)
class Line:
    """One spectral line of a record (:func:`find_lines`), in the channel's unit U.

    A coherent line is the sinusoid ``sine * sin(2 pi f t) + cosine * cos(2 pi f t)``, t in
    seconds from the record's first sample, of amplitude ``amplitude`` (its peak: the Allan
    variance of DESIGN.md's spectral-lines term, A^2 [sin^2(pi f tau) / (pi f tau)]^2, takes
    it); a broadened line has a ``band``, a ``width_hz`` and a ``power`` (its mean square),
    and no sinusoid (``sine`` and ``cosine`` zero).
    """

    frequency_hz: float
    """The line's frequency (a broadened line's: the centre of its excess power), Hz."""
    frequency_sd_hz: float
    """Its standard error (the Cramér-Rao bound for a coherent line; for a broadened one, the
    spread of its centre), Hz."""
    amplitude: float
    """Peak amplitude, U (sqrt(2 power) for a broadened line)."""
    amplitude_sd: float
    """Standard error of the amplitude at the record's local floor, U."""
    power: float
    """Mean square of the line, U^2 (A^2 / 2 for a coherent line)."""
    power_sd: float
    """Its standard error, U^2."""
    ratio: float
    """The test's statistic where it was found: the periodogram over its local floor (per
    ordinate of the sum, at a broadened line's scale)."""
    p_value: float
    """Its p-value, corrected for every frequency and scale looked at (Šidák)."""
    floor: float
    """The local floor of the samples' spectrum at the line: one-sided density, U^2/Hz."""
    log_likelihood_ratio: float = 0.0
    """Log likelihood ratio of the line against the floor alone: the peak ordinate over the
    floor for a sinusoid (the chi-square its two coefficients take out, halved); for a
    broadened line the excess over the floor summed over its band."""
    sine: float = 0.0
    cosine: float = 0.0
    broadened: bool = False
    width_hz: float = 0.0
    """Twice the rms spread of a broadened line's power about its centre, Hz (0: coherent)."""
    band_hz: tuple[float, float] = (0.0, 0.0)
    """The band a broadened line's power lies in, Hz (a coherent line's frequency, twice)."""


@dataclass(frozen=True)
class LineSearch:
    """The spectral lines of a record (:func:`find_lines`) and what the test looked at."""

    lines: tuple[Line, ...]
    """The lines found, by frequency."""
    rate_hz: float
    """The record's sample rate, Hz."""
    n_samples: int
    """The samples the test read (the longest run without a gap)."""
    searched: int
    """Frequencies looked at (per scale)."""
    level: float
    """The family-wise false-alarm probability."""
    threshold: float
    """The ratio (periodogram over a floor of many ordinates) a single ordinate must pass."""
    largest: dict = field(default_factory=dict)
    """The strongest ordinate the test did not call a line: ratio, frequency_hz, p_value
    (corrected); empty when none was tested."""
    coefficient_covariance: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)), repr=False)
    """(2 L, 2 L): the covariance of the coherent lines' (sine, cosine) coefficients per unit
    spectrum of the increments at each line (:meth:`coefficient_covariance_at`)."""
    note: str = ""
    """Why nothing was searched (a record too short, spooled), else empty."""

    @property
    def found(self) -> bool:
        """Whether any line was found."""
        return bool(self.lines)

    @property
    def tests(self) -> int:
        """Frequencies and scales looked at: the number the test corrects for."""
        return self.searched * len(SCALES)

    @property
    def log_bayes_factor(self) -> float:
        """The lines' evidence on Jeffreys' scale, approximately: each line's log likelihood
        ratio less the log of the frequencies and scales searched (its frequency's Occam
        factor). A line passes the test where it is about log(1 / level) (0.1 %: 6.9), which
        the term search's bar, log 100, reads as decisive."""
        return float(sum(line.log_likelihood_ratio - math.log(self.tests) for line in self.lines))

    @property
    def verdict(self) -> str:
        """What the test found, in words (for the term search's table)."""
        looked = (
            f"the periodogram test at family-wise {100 * self.level:g} % over {self.searched:,} "
            f"frequencies and {len(SCALES)} widths"
        )
        if self.note:
            return f"not searched: {self.note}"
        if not self.lines:
            largest = self.largest
            strongest = (
                f"; the strongest ordinate is {largest['ratio']:.1f}x its floor at "
                f"{largest['frequency_hz']:.6g} Hz, p = {largest['p_value']:.2g} corrected"
                if largest
                else ""
            )
            return f"no line found by {looked}{strongest}"
        broad = len(self.broadened)
        kinds = f" ({broad} broadened)" if broad else ""
        return f"{len(self.lines)} line(s){kinds} found by {looked}"

    @property
    def coherent(self) -> tuple[Line, ...]:
        """The lines fitted as sinusoids (not broadened)."""
        return tuple(line for line in self.lines if not line.broadened)

    @property
    def broadened(self) -> tuple[Line, ...]:
        """The broadened lines."""
        return tuple(line for line in self.lines if line.broadened)

    @property
    def resolution_hz(self) -> float:
        """The record's frequency resolution, rate / samples, Hz: two lines closer than about
        this are not told apart."""
        return self.rate_hz / self.n_samples if self.n_samples else math.inf

    @property
    def excluded_bands_hz(self) -> tuple[tuple[float, float], ...]:
        """The broadened lines' bands, Hz: a fit of the noise leaves them out."""
        return tuple(line.band_hz for line in self.broadened)

    @property
    def left_in(self) -> dict:
        """What the lines leave in the record less them, as a noise model's parameters (the
        spectral-lines term's): each broadened line as a line of its power, for the checks of
        a model fitted to that record; empty when every line is a sinusoid."""
        if not self.broadened:
            return {}
        return {
            "line_amplitude": tuple(line.amplitude for line in self.broadened),
            "line_frequency": tuple(line.frequency_hz for line in self.broadened),
        }

    def removed(self, values: np.ndarray) -> np.ndarray:
        """``values`` (at :attr:`rate_hz`, from the record's first sample; NaN stays NaN)
        less the coherent lines."""
        values = np.asarray(values, dtype=float)
        if not self.coherent:
            return values
        return values - self.line_sum(values.size)

    def flattened(self, values: np.ndarray) -> np.ndarray:
        """``values`` less the coherent lines (:meth:`removed`) and with each broadened line's
        band brought down to its local floor: the band's Fourier coefficients scaled by one
        factor so that their mean power is the floor's, E|X_k|^2 = S n f_s / 2 for a one-sided
        density S (phases and the ordinates' scatter kept). What a fit that must not read a
        broadened line as the noise's level (the output filter's decision) looks at; NaN stays
        NaN (the gaps are read as the mean while the band is scaled)."""
        values = self.removed(values)
        if not self.broadened:
            return values
        finite = np.isfinite(values)
        mean = float(np.mean(values[finite]))
        transform = np.fft.rfft(np.where(finite, values, mean) - mean)
        frequency = np.fft.rfftfreq(values.size, 1.0 / self.rate_hz)
        for line in self.broadened:
            inside = (frequency >= line.band_hz[0]) & (frequency <= line.band_hz[1])
            power = np.mean(np.abs(transform[inside]) ** 2) if inside.any() else 0.0
            target = line.floor * values.size * self.rate_hz / 2
            if power > target:
                transform[inside] *= math.sqrt(target / power)
        flat = np.fft.irfft(transform, values.size) + mean
        return np.where(finite, flat, np.nan)

    def line_sum(self, n: int) -> np.ndarray:
        """The coherent lines' sum at samples 0 .. n - 1, U."""
        time = np.arange(n) / self.rate_hz
        total = np.zeros(n)
        for line in self.coherent:
            phase = 2 * np.pi * line.frequency_hz * time
            total += line.sine * np.sin(phase) + line.cosine * np.cos(phase)
        return total

    def coefficient_covariance_at(self, spectrum) -> np.ndarray:
        """(..., 2 L, 2 L): the coherent lines' coefficient covariance where the increments'
        two-sided spectrum at each line (cycles per sample) is ``spectrum`` (..., L): the
        locally flat covariance of the module docstring, each line's rows and columns scaled
        by the root of its own."""
        root = np.repeat(np.sqrt(np.asarray(spectrum, dtype=float)), 2, axis=-1)
        return root[..., :, None] * self.coefficient_covariance * root[..., None, :]


class _Floors:
    """What the local floors of one periodogram are read from: the cumulative sums of its
    ordinates where ``usable`` and of the usable ordinates, padded on either side with their
    end values, so that a window reaching past an end reads as clipped there.

    A floor is the mean of the usable ordinates in two windows beside its centre (the module
    docstring): four reads of each cumulative sum (:meth:`at`). The scan's windows sit at
    every ordinate, millions at 2^23 samples: it reads a lower bound of their floors per
    block of them (:meth:`lower_bounds`) and the floors themselves only where that bound lets
    a window matter."""

    PAD = 2 * FLOOR_ORDINATES[1] + 2 * GUARD + max(SCALES) + 2
    """Padding each side: past the farthest a scan's window reads beyond either end."""

    def __init__(self, power: np.ndarray, usable: np.ndarray):
        self.size = power.size
        # Each cumulative sum is taken into its padded array (two arrays of the record's
        # length at 2^23 samples, not six).
        self.sums = self._padded(
            lambda out: np.cumsum(np.multiply(power, usable, out=out), out=out)
        )
        self.counts = self._padded(lambda out: np.cumsum(usable, dtype=float, out=out))
        # A window's sum is a difference of cumulative sums, each rounded to a part in 10^16
        # of the whole record's: a floor below that (a digital filter's stop band with no
        # noise after it, 13 decades down) reads as zero or less, and every ordinate above
        # it was a line of infinite ratio. Such a floor is not resolved: it counts nothing.
        self.resolution = 64 * np.finfo(float).eps * self.sums[-1]

    def _padded(self, cumulate) -> np.ndarray:
        """The cumulative sum ``cumulate(out)`` writes into ``out`` (the record's length),
        padded (the class docstring)."""
        padded = np.empty(self.size + 1 + 2 * self.PAD)
        padded[: self.PAD + 1] = 0.0
        cumulate(padded[self.PAD + 1 : self.PAD + 1 + self.size])
        padded[self.PAD + 1 + self.size :] = padded[self.PAD + self.size] if self.size else 0.0
        return padded

    @staticmethod
    def _read(cumulative, left: tuple, right: tuple):
        """The sum over ordinates [lo, hi) of ``left`` and of ``right``, each bound an index
        (array) of the padded sums: ordinate + PAD."""
        return (
            cumulative[left[1]] - cumulative[left[0]] + cumulative[right[1]] - cumulative[right[0]]
        )

    def _mean(self, left: tuple, right: tuple):
        """The floor (mean) and count over ordinates [lo, hi) of ``left`` and of ``right``
        (:meth:`_read`)."""
        total, count = self._read(self.sums, left, right), self._read(self.counts, left, right)
        count = np.where(total > self.resolution, count, 0.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            return total / count, count

    def at(self, centre, guard):
        """The floor at ordinates ``centre`` (arrays) beyond ``guard`` of each: the mean of
        the usable ordinates within the floor's half-width beside it, and their number."""
        centre, guard = np.asarray(centre, dtype=float), np.asarray(guard, dtype=float)
        half = _half_width(centre)
        bounds = (
            np.floor(centre - guard - half),
            np.ceil(centre - guard),
            np.floor(centre + guard + 1),
            np.ceil(centre + guard + 1 + half),
        )
        lo_left, hi_left, lo_right, hi_right = (
            np.clip(b.astype(int), 0, self.size) + self.PAD for b in bounds
        )
        return self._mean((lo_left, hi_left), (lo_right, hi_right))

    def lower_bounds(self, first: int, stop: int, width: int) -> tuple[np.ndarray, ...]:
        """Lower bounds of the floors of the windows of ``width`` ordinates starting at
        first .. stop - 1 (as :meth:`at` reads them, their guard GUARD beyond their edges),
        to screen the millions of windows of a long record (:func:`_scan`): (first windows,
        blocks, last windows). Below :data:`FULL_REACH` (a few thousand windows) and for the
        last few, each window's floor itself (infinite where too few ordinates make one);
        between, one bound per block of :data:`SCREEN_BLOCK` windows of the floor's full
        half-width h: the sum over the ordinates every window of the block averages (h - B +
        1 each side) over the most ordinates any of them averages (those, and B - 1 more each
        side). The periodogram is not negative, so no window's floor is below its block's
        bound; a block whose floors are not resolved is infinite."""
        guard = GUARD + (width - 1) / 2
        head_stop = max(first, min(stop, FULL_REACH))
        blocks = max(0, (stop - head_stop) // SCREEN_BLOCK)
        rest = np.arange(head_stop + blocks * SCREEN_BLOCK, stop)
        exact = np.concatenate((np.arange(first, head_stop), rest))
        floors, counts = self.at(exact + (width - 1) / 2, np.full(exact.size, guard))
        floors = np.where(counts >= MIN_FLOOR_ORDINATES, floors, np.inf)
        reach, extra = FLOOR_ORDINATES[1], SCREEN_BLOCK - 1
        first_block = head_stop + self.PAD

        def at(offset: int) -> slice:
            """The padded sums' index ``offset`` past each block's first window (strided:
            no index array to gather by)."""
            begin = first_block + offset
            return slice(begin, begin + SCREEN_BLOCK * blocks, SCREEN_BLOCK)

        left = (at(extra - GUARD - reach), at(-GUARD))
        right = (at(extra + width + GUARD), at(width + GUARD + reach))
        every = (at(-GUARD - reach), at(extra - GUARD))
        every_right = (at(width + GUARD), at(extra + width + GUARD + reach))
        # The sums' rounding (a few eps of the record's power) is far below their resolution
        # (:meth:`__init__`): taken off the shared sum, it leaves the bound a bound; a block
        # whose windows all read below half of it tests nothing (floors not resolved).
        shared = self._read(self.sums, left, right) - self.resolution
        count = self._read(self.counts, left, right)
        resolved = self._read(self.sums, every, every_right) > 0.5 * self.resolution
        block = np.where(resolved, np.maximum(shared, 0.0) / (count + 2 * extra), np.inf)
        head = head_stop - first
        return floors[:head], block, floors[head:]


FULL_REACH = math.ceil(FLOOR_ORDINATES[1] / FLOOR_FRACTION)
"""The ordinate from which every floor takes its largest half-width."""


def _half_width(centre: np.ndarray) -> np.ndarray:
    """The floor's half-width at ordinates ``centre``: :data:`FLOOR_FRACTION` of it, within
    :data:`FLOOR_ORDINATES` (float, whole numbers)."""
    return np.clip(np.round(FLOOR_FRACTION * centre), *FLOOR_ORDINATES)


@functools.lru_cache(maxsize=8)
def _ordinate_correlation(length: int) -> float:
    """The squared correlation of neighbouring ordinates of the tapered periodogram (white
    increments): |sum h^2 e^{-2 pi i k / M}|^2 / (sum h^2)^2. Kept for the lengths met (a
    third of a second at 2^20 samples; a notebook fits one record again and again)."""
    taper = tukey_window(length, TAPER_FRACTION)
    squares = taper**2
    shift = np.exp(-2j * np.pi * np.arange(length) / length)
    return float(abs(np.dot(squares, shift)) ** 2 / np.sum(squares) ** 2)


def _scale_dof(width: int, rho2: float) -> float:
    """Degrees of freedom of a sum of ``width`` neighbouring ordinates (2 each, less for
    their correlation ``rho2`` with their neighbours)."""
    if width == 1:
        return 2.0
    return 2.0 * width / (1.0 + 2.0 * rho2 * (width - 1) / width)


def _scan(power, usable, lowest, highest, line_index, rho2, alpha):
    """Per scale (width w): the starts of the windows that can matter, their ratio to the
    floor, the log of their p-values (F(2 w', 2 c)) and which are significant (p <
    ``alpha``); a window on a line already found is its residue, not tested (0).

    The windows that can matter are read exactly, the others only screened: a window's
    ratio is at most its sum over its floor's lower bound (:meth:`_Floors.lower_bounds`), and
    its p-value at least that ratio's under the most ordinates a floor averages (F's tail
    falls as its denominator's degrees of freedom grow). Read: every window that the screen
    lets reach significance, and at a single ordinate (w = 1) every one that could hold the
    smallest p-value (:func:`_largest`). The same windows are significant, with the same
    p-values and the same smallest one, as had every floor been read; at 2^23 samples the
    scan reads some thousands of floors instead of twelve million."""
    results = []
    log_alpha = math.log(alpha)
    floors = _Floors(power, usable)
    most = 2 * 2 * FLOOR_ORDINATES[1]  # the F's denominator degrees of freedom, at most
    # Each scale's ceilings are read before the next scale's are made: one array serves all
    # (at 2^23 samples, 33 MB each that the kernel would hand out and zero again).
    ceilings = np.empty(max(highest - lowest + 1, 0))
    for width in SCALES:
        stop = highest - width + 2
        if stop <= lowest:
            continue
        # A window of one ordinate sums it alone: no pass of np.convolve over the record.
        whole = power if width == 1 else np.convolve(power, np.ones(width), mode="valid")
        sums = whole[lowest:stop]
        ceiling = _ceilings(
            sums, width, *floors.lower_bounds(lowest, stop, width), out=ceilings[: sums.size]
        )
        dof = _scale_dof(width, rho2)
        # Significance's quantile a little low: its 1 - alpha rounds, and a window read in
        # excess costs a floor, one left unread a line.
        screen = 0.99 * special.fdtri(dof, most, 1.0 - alpha)
        read = np.flatnonzero(~(ceiling < screen))  # NaN (0 / 0): read
        if width == 1:
            # The window of the largest finite ceiling (an infinite one is a bound that says
            # nothing: a block's floors barely resolved) sets a p-value the smallest is at
            # most; every window whose ceiling could beat it is read next.
            finite = np.where(np.isfinite(ceiling), ceiling, -1.0)
            read = np.union1d(read, [int(np.argmax(finite))])
        ratio, log_p = _exact(floors, sums, read, lowest, width, line_index, dof)
        if width == 1:
            # p of a ratio x over c ordinates: (1 + x / c)^-c, at its smallest for the most c.
            c = most / 2
            beyond = c * np.expm1(-float(np.min(log_p)) / c)
            more = np.setdiff1d(np.flatnonzero(~(ceiling <= 0.99 * beyond)), read)
            if more.size:
                more_ratio, more_log_p = _exact(floors, sums, more, lowest, width, line_index, dof)
                order = np.argsort(np.concatenate((read, more)), kind="stable")
                read = np.concatenate((read, more))[order]
                ratio = np.concatenate((ratio, more_ratio))[order]
                log_p = np.concatenate((log_p, more_log_p))[order]
        results.append((width, lowest + read, ratio, log_p, log_p < log_alpha))
    return results


def _ceilings(sums, width: int, head, blocks, tail, out: np.ndarray) -> np.ndarray:
    """Each window's sum over ``width`` times its floor's lower bound
    (:meth:`_Floors.lower_bounds`: the first windows', one per block of the middle ones,
    the last windows'), the block's bound broadcast over its windows (not repeated), written
    into ``out`` (as long as ``sums``) and returned."""
    middle = slice(head.size, head.size + blocks.size * SCREEN_BLOCK)
    shape = (blocks.size, SCREEN_BLOCK)
    with np.errstate(divide="ignore", invalid="ignore"):
        np.divide(sums[: head.size], width * head, out=out[: head.size])
        np.divide(
            sums[middle].reshape(shape),
            (width * blocks)[:, None],
            out=out[middle].reshape(shape),
        )
        np.divide(sums[middle.stop :], width * tail, out=out[middle.stop :])
    return out


def _exact(floors, sums, read, lowest, width, line_index, dof):
    """The ratio to its floor and the log p-value under F(``dof``, 2 c) of the windows
    ``read`` (indices from ``lowest``) of ``sums``; 0 where a window is not tested (fewer
    than :data:`MIN_FLOOR_ORDINATES` in its floor, or on a line of ``line_index``)."""
    centre = lowest + read + (width - 1) / 2
    floor, count = floors.at(centre, np.full(read.size, GUARD + (width - 1) / 2))
    good = count >= MIN_FLOOR_ORDINATES
    ratio = np.where(good, sums[read] / (width * np.where(good, floor, 1.0)), 0.0)
    tested = good
    if line_index.size:
        distance = np.min(np.abs(centre[:, None] - line_index[None, :]), axis=1)
        tested = good & (distance >= 0.5 * width)
    log_p = np.zeros(read.size)
    log_p[tested] = _log_tail(ratio[tested], dof, 2 * count[tested])
    return ratio, log_p


def _log_tail(ratio, dfn, dfd):
    """log P(F(dfn, dfd) > ``ratio``): the log p-value of a ratio to its floor (0 at or below
    zero), as ``scipy.stats.f.logsf`` computes it: log of the upper tail above the median,
    log1p of minus the lower tail below it (there the upper tail rounds near 1). From
    ``scipy.special`` alone: importing ``scipy.stats`` costs every run that loads the line
    scan 0.5-1 s."""
    x = np.maximum(ratio, 0.0)
    with np.errstate(divide="ignore"):
        upper = np.log(special.fdtrc(dfn, dfd, x))
        lower = np.log1p(-special.fdtr(dfn, dfd, x))
    log_p = np.where(x > special.fdtri(dfn, dfd, 0.5), upper, lower)
    # At and below zero logsf gives 0.0, where log1p(-0.0) is -0.0.
    return np.where(x == 0.0, 0.0, log_p)


def _candidates(results, power, taken) -> list[tuple[int, bool]]:
    """(ordinate, whether a single ordinate is significant there) of each window significant
    at some scale that is the most significant within :data:`REACH` ordinates, at the
    largest ordinate of the window and two beside it, and not on an ordinate ``taken``."""
    best, single = {}, set()
    for width, starts, _, log_p, significant in results:
        for index in np.flatnonzero(significant):
            low = max(int(starts[index]) - 2, 1)
            peak = low + int(np.argmax(power[low : int(starts[index]) + width + 2]))
            # Ranked by p-value, then (where it underflows) by the power at the peak.
            rank = (float(log_p[index]), -float(power[peak]))
            best[peak] = min(best.get(peak, rank), rank)
            if width == 1:
                single.add(int(starts[index]))
    chosen = []
    for peak, _ in sorted(best.items(), key=lambda item: item[1]):
        if any(abs(peak - other) <= REACH for other, _ in chosen):
            continue
        if any(abs(peak - other) < 0.5 for other in taken):
            continue
        chosen.append((peak, bool({peak - 1, peak, peak + 1} & single)))
    return chosen


@functools.lru_cache(maxsize=4)
def _block_phasors(key: bytes) -> np.ndarray:
    """(_CHUNK, L): e^{2 pi i nu k}, k = 0 .. _CHUNK - 1, for the frequencies whose bytes
    are ``key`` (cycles per sample). A block's phasors are these times its first sample's
    (:func:`_phasors`); kept for the frequencies of the last few fits of a search, each of
    which reads every block of the record twice or more, and dropped when it ends."""
    nu = np.frombuffer(key)
    return np.exp(2j * np.pi * np.arange(_CHUNK, dtype=float)[:, None] * nu[None, :])


def _phasors(nu: np.ndarray, first: float, count: int) -> np.ndarray:
    """(count, L): e^{2 pi i nu t} at t = first .. first + count - 1: block by block, the
    block's first sample's phasor times the block's (:func:`_block_phasors`), one complex
    product a sample where a sine and a cosine of each were most of the cost of fitting a
    record's lines."""
    nu = np.ascontiguousarray(nu, dtype=float)
    block = _block_phasors(nu.tobytes())
    phasors = np.empty((count, nu.size), dtype=complex)
    for start in range(0, count, _CHUNK):
        stop = min(start + _CHUNK, count)
        phasors[start:stop] = np.exp(2j * np.pi * nu[None, :] * (first + start))
        phasors[start:stop] *= block[: stop - start]
    return phasors


def _regressors(nu: np.ndarray, start: int, stop: int, offset: int) -> np.ndarray:
    """(stop - start, 1 + 2 L): a constant and the increments of sin(2 pi nu t) and
    cos(2 pi nu t) (t the sample index from the record's start, ``offset`` that of the run's
    first sample) at increments start .. stop - 1: 2 sin(pi nu) cos(2 pi nu (t + 1/2)) and
    -2 sin(pi nu) sin(2 pi nu (t + 1/2))."""
    half = np.sin(np.pi * nu)[None, :]
    phasors = _phasors(nu, start + offset + 0.5, stop - start)
    columns = np.empty((stop - start, 1 + 2 * nu.size))
    columns[:, 0] = 1.0
    columns[:, 1::2] = 2 * half * phasors.real
    columns[:, 2::2] = -2 * half * phasors.imag
    return columns


def _least_squares(increments, weight, nu, offset):
    """The weighted least-squares fit of the increments on the lines at ``nu`` and a
    constant: coefficients (1 + 2 L), the fitted increments, and the coefficients'
    covariance for white increments of unit variance, (X'WX)^-1 X'W^2X (X'WX)^-1. Summed in
    blocks of :data:`_CHUNK` samples (the regressors of a long record would not fit)."""
    size = 1 + 2 * nu.size
    gram, cross, fourth = np.zeros((size, size)), np.zeros(size), np.zeros((size, size))
    for start in range(0, increments.size, _CHUNK):
        stop = min(start + _CHUNK, increments.size)
        columns = _regressors(nu, start, stop, offset)
        weighted = columns * weight[start:stop, None]
        gram += weighted.T @ columns
        cross += weighted.T @ increments[start:stop]
        fourth += weighted.T @ weighted
    inverse = np.linalg.pinv(gram)
    coefficients = inverse @ cross
    fitted = np.empty_like(increments)
    for start in range(0, increments.size, _CHUNK):
        stop = min(start + _CHUNK, increments.size)
        fitted[start:stop] = _regressors(nu, start, stop, offset) @ coefficients
    return coefficients, fitted, inverse @ fourth @ inverse


def _frequency_columns(nu, coefficients, start: int, stop: int, offset: int) -> np.ndarray:
    """(stop - start, L): the derivative of the fitted increments by each line's frequency
    (cycles per sample): the increments of g(t) = 2 pi t Re((a + i b) e^{2 pi i nu t}),
    taken as 2 pi (t Re((a + i b) z_t (e^{i w} - 1)) + Re((a + i b) z_t e^{i w})), z_t the
    phasor and w = 2 pi nu: g(t + 1) - g(t) itself lost as many digits as t has to
    cancellation, which the frequencies' covariance inherited (a part in 10^5 at 2^21
    samples)."""
    t = np.arange(start, stop, dtype=float)[:, None] + offset
    omega = 2 * np.pi * nu[None, :]
    turned = (coefficients[1::2] + 1j * coefficients[2::2])[None, :] * _phasors(
        nu, start + offset, stop - start
    )
    step = 2j * np.sin(omega / 2) * np.exp(0.5j * omega)  # e^{i w} - 1, without cancelling
    return 2 * np.pi * (t * (turned * step).real + (turned * np.exp(1j * omega)).real)


def _jacobian_sums(spectrum, nu, coefficients, residual=None, fourth=True):
    """J'WJ, J'W^2J (with ``fourth``) and J'W r over the record: J the fitted increments'
    Jacobian (a constant, every line's coefficients, then every line's frequency), in
    blocks."""
    size = 1 + 3 * nu.size
    gram, squares, cross = np.zeros((size, size)), np.zeros((size, size)), np.zeros(size)
    for start in range(0, spectrum.size, _CHUNK):
        stop = min(start + _CHUNK, spectrum.size)
        columns = np.concatenate(
            (
                _regressors(nu, start, stop, spectrum.offset),
                _frequency_columns(nu, coefficients, start, stop, spectrum.offset),
            ),
            axis=1,
        )
        weighted = columns * spectrum.weight[start:stop, None]
        gram += weighted.T @ columns
        if fourth:
            squares += weighted.T @ weighted
        if residual is not None:
            cross += weighted.T @ residual[start:stop]
    return gram, squares, cross


def _gauss_newton(spectrum, nu: np.ndarray, coefficients, fitted, steps: int = 4) -> np.ndarray:
    """The frequencies of lines within :data:`CLUSTER` ordinates of each other refined
    jointly, cluster by cluster (the record less the other lines): Gauss-Newton steps of the
    weighted least squares of the increments, each line's coefficients refitted at every
    step — which separates lines a little over an ordinate apart where one at a time does
    not."""
    order = np.argsort(nu)
    gaps = np.diff(nu[order]) * spectrum.size
    edges = np.flatnonzero(np.diff(np.concatenate(([0], (gaps < CLUSTER).astype(np.int8), [0]))))
    nu = nu.copy()
    for start, stop in zip(edges[::2], edges[1::2], strict=True):
        members = order[start : stop + 1]
        data = spectrum.increments - fitted
        for k in members:
            data = data + spectrum.own(nu, coefficients, k)
        group = nu[members]
        for _ in range(steps):
            local, local_fit, _ = _least_squares(data, spectrum.weight, group, spectrum.offset)
            gram, _, cross = _jacobian_sums(spectrum, group, local, data - local_fit, False)
            step = (np.linalg.pinv(gram) @ cross)[1 + 2 * group.size :]
            step = np.clip(step, -0.25 / spectrum.size, 0.25 / spectrum.size)
            group = group + step
            if np.max(np.abs(step)) < 1e-7 / spectrum.size:
                break
        nu[members] = group
    return nu


def _joint_covariance(spectrum, nu: np.ndarray, coefficients: np.ndarray) -> np.ndarray:
    """(3 L, 3 L): the covariance of every line's (sine, cosine) coefficients, then every
    line's frequency (cycles per sample), for white increments of unit variance: the
    weighted least-squares sandwich (J'WJ)^-1 J'W^2J (J'WJ)^-1 of the Jacobian J of the
    fitted increments (a constant beside them; taken out) — the Cramér-Rao form of the
    frequencies' errors, their neighbours' included."""
    if nu.size == 0:  # the constant alone: no line's covariance (no pass over the record)
        return np.zeros((0, 0))
    gram, fourth, _ = _jacobian_sums(spectrum, nu, coefficients)
    inverse = np.linalg.pinv(gram)
    return (inverse @ fourth @ inverse)[1:, 1:]


def _interpolated(power: np.ndarray, peak: int) -> float:
    """The peak of a parabola through the log periodogram at ``peak`` and its neighbours."""
    low, middle, high = np.log(np.maximum(power[peak - 1 : peak + 2], 1e-300))
    curvature = low - 2 * middle + high
    return peak + (0.5 * (low - high) / curvature if curvature < 0 else 0.0)


def _refined(residual, weight, nu: float) -> float:
    """The frequency (cycles per sample) near ``nu`` that maximises |sum w r e^{-2 pi i nu t}|
    (the weighted least-squares frequency of one sinusoid in ``residual``): Newton's method
    from ``nu``, from the best of a 1/8-ordinate grid over +-1 ordinate where it does not
    start concave."""
    size = residual.size
    t = np.arange(size, dtype=float)
    weighted = weight * residual
    moments = np.stack((weighted, weighted * t, weighted * t * t), axis=1)
    best = nu
    for attempt in range(2):
        for _ in range(8):
            y0, y1, y2 = _transforms(moments, np.array([best]))[:, 0]
            y1, y2 = y1 * (-2j * np.pi), y2 * (-4 * np.pi**2)
            first = 2 * (np.conj(y0) * y1).real
            second = 2 * (np.conj(y1) * y1 + np.conj(y0) * y2).real
            if not second < 0:
                break
            step = float(np.clip(-first / second, -0.25 / size, 0.25 / size))
            best += step
            if abs(step) < 1e-7 / size:
                return best
        else:
            return best
        if attempt == 0:
            grid = nu + np.arange(-8, 9) / (8.0 * size)
            strength = np.abs(_transforms(moments[:, :1], grid)[0])
            best = float(grid[int(np.argmax(strength))])
    return best


def _transforms(columns: np.ndarray, nu: np.ndarray) -> np.ndarray:
    """(columns, L): sum_t c_t e^{-2 pi i nu t} of each column of ``columns`` (samples,
    columns) at each frequency ``nu`` (cycles per sample), block by block."""
    total = np.zeros((columns.shape[1], nu.size), dtype=complex)
    for start in range(0, columns.shape[0], _CHUNK):
        stop = min(start + _CHUNK, columns.shape[0])
        total += columns[start:stop].T @ _phasors(-nu, start, stop - start)
    return total


def _usable(size: int, highest: int, positions) -> np.ndarray:
    """Which ordinates (0 .. size - 1) may stand in a floor: 1 .. highest, away from the
    lines at ``positions`` (ordinates) by more than :data:`GUARD`. Each line's test is
    made on the ordinates beside it only (those farther are away from it): four million
    ordinates at 2^23 samples, a pass over them each."""
    usable = np.zeros(size, dtype=bool)
    usable[1 : max(highest + 1, 0)] = True
    for position in positions:
        lo, hi = 0, size
        if math.isfinite(position):
            lo = min(max(math.floor(position) - GUARD - 1, 0), size)
            hi = max(min(math.ceil(position) + GUARD + 2, size), lo)
        usable[lo:hi] &= np.abs(np.arange(lo, hi) - position) > GUARD
    return usable


class _Spectrum:
    """The record's increments, their taper, and what the test reads of them."""

    def __init__(
        self,
        increments: np.ndarray,
        offset: int,
        rate_hz: float,
        level: float,
        transform: RecordTransform | None = None,
    ):
        self.increments, self.offset, self.rate_hz = increments, offset, rate_hz
        self._transform = transform  # the increments' tapered transform, where handed in
        self.size = increments.size
        self.taper = (
            tukey_window(self.size, TAPER_FRACTION) if transform is None else transform.taper
        )
        self.lowest, self.highest = LOWEST_CYCLES, (self.size - 1) // 2
        self.searched = max(self.highest - self.lowest + 1, 1)
        self.tests = self.searched * len(SCALES)
        self.alpha = -math.expm1(math.log1p(-level) / self.tests)
        self.rho2 = _ordinate_correlation(self.size)
        self._unfitted = self._unfitted_scan = None

    @functools.cached_property
    def weight(self) -> np.ndarray:
        """The squared taper: the lines' least squares weights (made where lines are fitted:
        a record without any never needs them)."""
        return self.taper**2

    def periodogram(self, fitted: np.ndarray) -> np.ndarray:
        """The periodogram of the increments less ``fitted``. With nothing fitted it is the
        record's own, kept: the search's first round and the description of a record without
        lines both read it (an FFT of the whole record each), from the transform handed in
        where there is one."""
        if fitted.any():
            _, transform = tapered_transform(self.increments - fitted, self.taper)
            return transform_power(transform, tukey_energy(self.size, TAPER_FRACTION))
        if self._unfitted is None:
            transform = (
                tapered_transform(self.increments, self.taper)[1]
                if self._transform is None
                else self._transform.transform
            )
            self._unfitted = transform_power(transform, tukey_energy(self.size, TAPER_FRACTION))
        return self._unfitted

    def scan(self, power: np.ndarray, positions) -> list:
        """:func:`_scan` of ``power`` with lines at ``positions`` (ordinates); that of the
        record's own periodogram with no line is kept, as the periodogram is."""
        positions = np.asarray(positions, dtype=float)
        if power is self._unfitted and positions.size == 0 and self._unfitted_scan is not None:
            return self._unfitted_scan
        usable = _usable(power.size, self.highest, positions)
        results = _scan(power, usable, self.lowest, self.highest, positions, self.rho2, self.alpha)
        if power is self._unfitted and positions.size == 0:
            self._unfitted_scan = results
        return results

    def fit(self, nu: np.ndarray):
        """(coefficients, fitted increments, covariance per unit spectrum) of lines at
        ``nu`` (cycles per sample)."""
        if nu.size == 0:
            return np.zeros(1), np.zeros(self.size), np.zeros((1, 1))
        return _least_squares(self.increments, self.weight, nu, self.offset)

    def own(self, nu: np.ndarray, coefficients: np.ndarray, k: int) -> np.ndarray:
        """Line k's fitted increments."""
        columns = _regressors(nu[k : k + 1], 0, self.size, self.offset)[:, 1:]
        return columns @ coefficients[1 + 2 * k : 3 + 2 * k]

    def corrected(self, p_value: float) -> float:
        """A p-value corrected for every test (Šidák)."""
        return float(-np.expm1(self.tests * np.log1p(-min(p_value, 1.0 - 1e-16))))

    def floor_at(self, power: np.ndarray, usable: np.ndarray, centre: float, guard: float):
        """The local floor of ``power`` at ordinate ``centre`` beyond ``guard``, and the
        ordinates it averages."""
        floor, count = _Floors(power, usable).at(np.array([centre]), np.array([guard]))
        return float(floor[0]), float(count[0])


def _search(spectrum: _Spectrum, max_lines: int) -> tuple[np.ndarray, list[tuple[int, int]]]:
    """The lines found, round by round (module docstring): the sinusoids' frequencies
    (cycles per sample) and the broadened lines' bands (ordinates [lo, hi]). Sinusoids packed
    closer than the record resolves are a broadened line (:func:`_packed`)."""
    nu, bands = np.zeros(0), []
    coefficients, fitted = np.zeros(1), np.zeros(spectrum.size)
    for _ in range(MAX_ROUNDS):
        if nu.size + len(bands) >= max_lines:
            break
        power = spectrum.periodogram(fitted)
        positions = _positions(spectrum, nu, bands)
        found = _candidates(spectrum.scan(power, positions), power, positions[nu.size :])
        if not found:
            break
        usable = _usable(power.size, spectrum.highest, positions)
        starts = []
        for peak, single in found[: max_lines - nu.size - len(bands)]:
            if single or np.any(np.abs(nu * spectrum.size - peak) < RESIDUE):
                starts.append(_interpolated(power, peak) / spectrum.size)
            else:  # power over several ordinates, none a sinusoid's alone
                bands.append(_broad_band(spectrum, power, usable, peak))
        if not starts:
            continue
        nu = np.concatenate((nu, starts))
        coefficients, fitted, _ = spectrum.fit(nu)
        for _sweep in range(2):  # each line's frequency given the others, then all refitted
            moved = nu.copy()
            for k in range(nu.size):
                own = spectrum.own(nu, coefficients, k)
                moved[k] = _refined(spectrum.increments - fitted + own, spectrum.weight, nu[k])
            nu = moved
            coefficients, fitted, _ = spectrum.fit(nu)
        nu = _gauss_newton(spectrum, nu, coefficients, fitted)
        coefficients, fitted, _ = spectrum.fit(nu)
        packed = _packed(nu * spectrum.size)
        nu, coefficients, fitted = _to_bands(spectrum, nu, coefficients, fitted, packed, bands)
    broad = _broadened(spectrum, nu, coefficients, fitted, bands)
    nu, _, _ = _to_bands(spectrum, nu, coefficients, fitted, broad, bands)
    bands = _merged(bands)
    # A sinusoid inside a broadened line's band is part of its power.
    position = nu * spectrum.size
    inside = np.zeros(nu.size, dtype=bool)
    for lo, hi in bands:
        inside |= (position >= lo - GUARD) & (position <= hi + GUARD)
    return np.sort(nu[~inside]), bands


def _merged(bands: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """Bands that overlap or lie within the floor's reach of each other joined: one
    broadened line, found in pieces."""
    joined = []
    for lo, hi in sorted(bands):
        reach = max(REACH, round(FLOOR_FRACTION * lo))
        if joined and lo - joined[-1][1] <= reach:
            joined[-1] = (joined[-1][0], max(hi, joined[-1][1]))
        else:
            joined.append((lo, hi))
    return joined


def _packed(positions: np.ndarray) -> np.ndarray:
    """Sinusoids packed closer than the record resolves (ordinates ``positions``): two less
    than :data:`RESOLVED` apart, or three or more each within :data:`COMB` of the next — a
    broadened line that sinusoids were fitted to piece by piece."""
    order = np.argsort(positions)
    gaps = np.diff(positions[order])
    packed = np.zeros(positions.size, dtype=bool)
    for k in np.flatnonzero(gaps < RESOLVED):
        packed[order[k]] = packed[order[k + 1]] = True
    close = np.concatenate(([False], gaps <= COMB, [False]))
    edges = np.flatnonzero(np.diff(close.astype(np.int8)))
    for start, stop in zip(edges[::2], edges[1::2], strict=True):
        if stop - start >= 2:  # two gaps or more: three sinusoids or more
            packed[order[start : stop + 1]] = True
    return packed


def _to_bands(spectrum, nu, coefficients, fitted, broad, bands):
    """The sinusoids at ``nu`` less those flagged ``broad``, whose bands join ``bands``
    (in place); with the fit of what is left."""
    if not broad.any():
        return nu, coefficients, fitted
    usable = _usable(spectrum.size // 2 + 1, spectrum.highest, _positions(spectrum, nu, bands))
    for k in np.flatnonzero(broad):
        raw = spectrum.periodogram(fitted - spectrum.own(nu, coefficients, k))
        bands.append(_broad_band(spectrum, raw, usable, round(float(nu[k] * spectrum.size))))
    nu = nu[~broad]
    coefficients, fitted, _ = spectrum.fit(nu)
    return nu, coefficients, fitted


def _positions(spectrum: _Spectrum, nu: np.ndarray, bands) -> np.ndarray:
    """The ordinates taken by lines found: each sinusoid's, and every one of a broadened
    line's band."""
    spread = [np.arange(lo, hi + 1) for lo, hi in bands]
    return np.concatenate((nu * spectrum.size, *spread)).astype(float)


def _broadened(spectrum, nu, coefficients, fitted, bands) -> np.ndarray:
    """Which sinusoids at ``nu`` are broadened: an isolated line's power left around it after
    the sinusoids are taken out, within the floor's reach, is significant (corrected for the
    lines tested) and at least :data:`BROAD_SHARE` of the line's."""
    residual = spectrum.periodogram(fitted)
    usable = _usable(residual.size, spectrum.highest, _positions(spectrum, nu, bands))
    flags = np.zeros(nu.size, dtype=bool)
    for k in range(nu.size):
        centre = round(float(nu[k] * spectrum.size))
        reach = int(max(REACH, round(FLOOR_FRACTION * centre)))
        if np.sum(np.abs(nu * spectrum.size - centre) <= reach) > 1:
            continue  # a neighbour's power is no broadening: only an isolated line's
        floor, count = spectrum.floor_at(residual, usable, centre, reach)
        if not (count >= 4 and floor > 0):
            continue
        lo, hi = max(centre - reach, 1), min(centre + reach, spectrum.highest)
        left = float(np.sum(residual[lo : hi + 1] - floor))
        if not left > 0:
            continue
        raw = spectrum.periodogram(fitted - spectrum.own(nu, coefficients, k))
        whole = float(np.sum(raw[lo : hi + 1] - floor))
        width = hi - lo + 1
        ratio = float(np.sum(residual[lo : hi + 1])) / (width * floor)
        log_p = _log_tail(ratio, _scale_dof(width, spectrum.rho2), 2 * count)
        significant = log_p + math.log(nu.size) < math.log(spectrum.alpha * spectrum.tests)
        flags[k] = bool(left >= BROAD_SHARE * whole and significant)
    return flags


def _broad_band(spectrum: _Spectrum, raw: np.ndarray, usable, peak: int) -> tuple[int, int]:
    """The ordinates [lo, hi] around ``peak`` where ``raw`` (3-ordinate mean) holds at least
    twice its floor (taken beyond the floor's reach)."""
    reach = int(max(REACH, round(FLOOR_FRACTION * peak)))
    floor, _ = spectrum.floor_at(raw, usable, peak, reach)
    smooth = np.convolve(raw, np.ones(3) / 3, mode="same")
    lo = hi = peak
    while lo - 1 >= 1 and smooth[lo - 1] >= 2 * floor and peak - lo < reach:
        lo -= 1
    while hi + 1 <= spectrum.highest and smooth[hi + 1] >= 2 * floor and hi - peak < reach:
        hi += 1
    return lo, hi


def _coherent_line(spectrum, nu, k, coefficients, joint, fitted, residual, usable) -> Line:
    """Line k of the sinusoids at ``nu``: its estimates and their standard errors at the
    local floor of ``residual`` (the periodogram of the record less every line; ``joint``
    the coefficients' and frequencies' covariance per unit floor, :func:`_joint_covariance`)."""
    size, rate, lines = spectrum.size, spectrum.rate_hz, nu.size
    centre = float(nu[k] * size)
    floor, count = spectrum.floor_at(residual, usable, centre, GUARD)
    sine, cosine = (float(c) for c in coefficients[1 + 2 * k : 3 + 2 * k])
    block = floor * joint[2 * k : 2 * k + 2, 2 * k : 2 * k + 2]
    amplitude = math.hypot(sine, cosine)
    gradient = np.array([sine, cosine]) / max(amplitude, 1e-300)
    amplitude_sd = math.sqrt(max(float(gradient @ block @ gradient), 0.0))
    frequency_sd = math.sqrt(max(floor * joint[2 * lines + k, 2 * lines + k], 0.0))
    level = floor / (4 * math.sin(math.pi * nu[k]) ** 2)  # the samples' spectrum there
    alone = spectrum.periodogram(fitted - spectrum.own(nu, coefficients, k))
    peak = round(centre)
    ratio = float(np.max(alone[max(peak - 1, 1) : peak + 2]) / floor)
    log_p = float(_log_tail(ratio, 2, 2 * max(count, 1)))
    frequency = float(nu[k] * rate)
    return Line(
        frequency_hz=frequency,
        frequency_sd_hz=frequency_sd * rate,
        amplitude=amplitude,
        amplitude_sd=amplitude_sd,
        power=amplitude**2 / 2,
        power_sd=amplitude * amplitude_sd,
        ratio=ratio,
        p_value=spectrum.corrected(math.exp(log_p)),
        floor=2 * level / rate,
        log_likelihood_ratio=ratio,
        sine=sine,
        cosine=cosine,
        band_hz=(frequency, frequency),
    )


def _broad_line(spectrum, band: tuple[int, int], raw: np.ndarray, usable: np.ndarray) -> Line:
    """A broadened line over the ordinates ``band`` of ``raw`` (the periodogram of the record
    less the sinusoids): its power, centre and width (module docstring)."""
    size, rate = spectrum.size, spectrum.rate_hz
    lo, hi = band
    index = np.arange(lo, hi + 1)
    centre = 0.5 * (lo + hi)
    reach = max(REACH, round(FLOOR_FRACTION * centre)) + 0.5 * (hi - lo)
    floor, count = spectrum.floor_at(raw, usable, centre, reach)
    gain = 4 * np.sin(np.pi * index / size) ** 2
    excess = np.maximum(raw[index] - floor, 0.0) / gain
    power = float(2 * np.sum(excess) / size)
    power_sd = float(2 * np.sqrt(np.sum((raw[index] / gain) ** 2)) / size)
    weights = excess / max(np.sum(excess), 1e-300)
    mean = float(np.sum(weights * index))
    spread = math.sqrt(max(float(np.sum(weights * (index - mean) ** 2)), 0.0))
    ratio = float(np.sum(raw[index]) / (index.size * floor))
    dof = _scale_dof(index.size, spectrum.rho2)
    log_p = float(_log_tail(ratio, dof, 2 * max(count, 1)))
    amplitude = math.sqrt(2 * power)
    level = floor / (4 * math.sin(math.pi * mean / size) ** 2)
    return Line(
        frequency_hz=mean * rate / size,
        frequency_sd_hz=max(spread, 0.5) * rate / size / math.sqrt(index.size),
        amplitude=amplitude,
        amplitude_sd=power_sd / max(amplitude, 1e-300),
        power=power,
        power_sd=power_sd,
        ratio=ratio,
        p_value=spectrum.corrected(math.exp(log_p)),
        floor=2 * level / rate,
        log_likelihood_ratio=float(np.sum(raw[index] / floor - 1.0)),
        broadened=True,
        width_hz=2 * spread * rate / size,
        band_hz=(lo * rate / size, hi * rate / size),
    )


def _largest(spectrum: _Spectrum, results) -> dict:
    """The strongest single ordinate not called a line: its ratio, frequency and corrected
    p-value."""
    for width, starts, ratio, log_p, _ in results:
        if width == 1 and starts.size:
            index = int(np.argmin(log_p))
            return {
                "ratio": float(ratio[index]),
                "frequency_hz": float(starts[index] * spectrum.rate_hz / spectrum.size),
                "p_value": spectrum.corrected(math.exp(float(log_p[index]))),
            }
    return {}


def _described(spectrum: _Spectrum, nu: np.ndarray, bands, level: float) -> LineSearch:
    """The sinusoids at ``nu`` and the broadened lines over ``bands``, each described
    (module docstring)."""
    coefficients, fitted, _ = spectrum.fit(nu)
    joint = _joint_covariance(spectrum, nu, coefficients)
    residual = spectrum.periodogram(fitted)
    positions = _positions(spectrum, nu, bands)
    usable = _usable(residual.size, spectrum.highest, positions)
    lines = [
        _coherent_line(spectrum, nu, k, coefficients, joint, fitted, residual, usable)
        for k in range(nu.size)
    ]
    lines += [_broad_line(spectrum, band, residual, usable) for band in bands]
    return LineSearch(
        lines=tuple(sorted(lines, key=lambda line: line.frequency_hz)),
        rate_hz=spectrum.rate_hz,
        n_samples=spectrum.size + 1,
        searched=spectrum.searched,
        level=level,
        threshold=float(-math.log(spectrum.alpha)),
        largest=_largest(spectrum, spectrum.scan(residual, positions)),
        coefficient_covariance=joint[: 2 * nu.size, : 2 * nu.size],
    )


def find_lines(
    values,
    rate_hz: float,
    *,
    level: float = LINE_LEVEL,
    max_lines: int = MAX_LINES,
    transform: RecordTransform | None = None,
) -> LineSearch:
    """The spectral lines of a record (module docstring).

    Parameters
    ----------
    values : array_like
        The samples, U (NaN marks a missing one: the longest run without one is searched,
        and the lines found hold for the whole record).
    rate_hz : float
        Sample rate, Hz.
    level : float
        The probability that a record without lines shows one.
    max_lines : int
        The most lines looked for.
    transform : RecordTransform, optional
        The tapered transform of the record's longest run without a gap
        (:func:`~bayescal.classical._periodogram.longest_run_transform` of ``values``), where
        the caller has it: the record's periodogram is read from it, not computed again.

    Returns
    -------
    LineSearch
        The lines, each with its frequency, amplitude (or power and width) and their
        standard errors, and what the test looked at.

    Examples
    --------
    >>> import numpy as np
    >>> from bayescal.classical._lines import find_lines
    >>> t = np.arange(2**14) / 100.0
    >>> y = np.random.default_rng(0).normal(0, 1, t.size) + 0.5 * np.sin(2 * np.pi * 12.3 * t)
    >>> [round(line.frequency_hz, 3) for line in find_lines(y, 100.0).lines]
    [12.3]
    """
    empty = LineSearch((), rate_hz, 0, 0, level, math.inf)
    if is_spooled(values):
        return dataclasses.replace(empty, note="a spooled record is not searched for lines")
    values = np.asarray(values, dtype=float)
    run = longest_run(values)
    if run is None:
        return dataclasses.replace(empty, note="no samples")
    start, stop = run
    if stop - start - 1 < MIN_SAMPLES:
        return dataclasses.replace(
            empty, note=f"a record shorter than {MIN_SAMPLES} samples is not searched for lines"
        )
    shared = transform is not None and transform.of(start, stop)
    if shared:
        increments = transform.increments
    else:
        increments = np.diff(values[start:stop])
        increments = increments[: fast_length_at_most(increments.size)]
    spectrum = _Spectrum(increments, start, float(rate_hz), level, transform if shared else None)
    try:
        return _described(spectrum, *_search(spectrum, max_lines), level)
    finally:
        # The phasors are of this record's frequencies, up to 25 MB each: none serves another.
        _block_phasors.cache_clear()
