"""Confidence intervals of Allan-family deviations.

Three steps, as NIST SP 1065 (Riley 2008, sections 5.3-5.6) lays them out:

1. identify the dominant power-law noise at each averaging factor m — the exponent ``alpha``
   of the frequency (rate) spectrum S_y(f) ~ f^alpha: +2 white phase (quantization), +1
   flicker phase, 0 white frequency (angle/velocity random walk), -1 flicker frequency (bias
   instability), -2 random-walk frequency (rate random walk) — by the lag-1 autocorrelation
   (Riley & Greenhall 2004) where at least 30 points remain, else by the B1 bias ratio and
   R(n) (SP 1065 section 5.6.2);
2. compute the equivalent degrees of freedom with Greenhall's algorithm (Greenhall & Riley,
   "Uncertainty of stability variances based on finite differences", PTTI 2003);
3. turn the chi-square distribution with that EDF into an interval (SP 1065 eq. 45).
"""

import math

import numpy as np
from scipy import special

from .._errors import InputError

_LAG1_MIN_POINTS = 30
# The lag-1 autocorrelation of 2^17 points has a standard error of 0.003, far below what
# moves the rounded exponent; longer decimated records are cut to this many points.
_LAG1_MAX_POINTS = 2**17
_J_MAX = 100

# Greenhall & Riley (2003) Tables 1 and 2: (a0, a1) by alpha = 2 .. -4 (rows) and d = 1 .. 3.
_TABLE1_MODIFIED = {
    2: ((2 / 3, 1 / 3), (7 / 9, 1 / 2), (22 / 25, 2 / 3)),
    1: ((0.840, 0.345), (0.997, 0.616), (1.141, 0.843)),
    0: ((1.079, 0.368), (1.033, 0.607), (1.184, 0.848)),
    -1: (None, (1.048, 0.534), (1.180, 0.816)),
    -2: (None, (1.302, 0.535), (1.175, 0.777)),
    -3: (None, None, (1.194, 0.703)),
    -4: (None, None, (1.489, 0.702)),
}
_TABLE2_UNMODIFIED = {
    2: ((3 / 2, 1 / 2), (35 / 18, 1.0), (231 / 100, 3 / 2)),
    1: ((78.6, 25.2), (790.0, 410.0), (9950.0, 6520.0)),
    0: ((2 / 3, 1 / 6), (2 / 3, 1 / 3), (7 / 9, 1 / 2)),
    -1: (None, (0.852, 0.375), (0.997, 0.617)),
    -2: (None, (1.079, 0.368), (1.033, 0.607)),
    -3: (None, None, (1.053, 0.553)),
    -4: (None, None, (1.302, 0.535)),
}
# Table 3: (b0, b1) for flicker phase noise (alpha = 1), d = 1 .. 3.
_TABLE3_FLICKER_PHASE = ((6.0, 4.0), (15.23, 12.0), (47.8, 40.0))


def _generalized_autocovariance(t, alpha):
    """s_w(t) of Greenhall & Riley eq. (7), up to a sign per alpha that cancels in the EDF."""
    t = np.abs(np.asarray(t, dtype=float))
    power = 2 - alpha  # alpha = 2 -> |t|, 1 -> t^2 log t, 0 -> |t|^3, ...
    if alpha % 2 == 0:
        return t ** (power + 1) * (-1.0 if alpha == 2 else 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(t == 0.0, 0.0, t ** (power + 1) * np.log(np.where(t == 0.0, 1.0, t)))


def _filtered_autocovariance(t, filter_factor, alpha):
    """s_x(t) of eq. (8): the phase filtered by an F-point average (F = inf: no average)."""
    if math.isinf(filter_factor):
        return _generalized_autocovariance(t, alpha + 2)
    step = 1.0 / filter_factor
    return filter_factor**2 * (
        2 * _generalized_autocovariance(t, alpha)
        - _generalized_autocovariance(t - step, alpha)
        - _generalized_autocovariance(t + step, alpha)
    )


def _difference_autocovariance(t, filter_factor, alpha, d):
    """s_z(t) of eq. (9): autocovariance of the d-th difference of the filtered phase."""
    total = 0.0
    for k in range(-d, d + 1):
        weight = (-1) ** k * special.comb(2 * d, d + k, exact=True)
        total = total + weight * _filtered_autocovariance(np.asarray(t) + k, filter_factor, alpha)
    return total


def _basic_sum(n_terms, n_estimator, stride, filter_factor, alpha, d):
    """Eq. (10): sum over lags of squared normalised autocovariances of the estimator terms."""
    lags = np.arange(1, int(n_terms))
    inner = _difference_autocovariance(lags / stride, filter_factor, alpha, d) ** 2
    return (
        _difference_autocovariance(0.0, filter_factor, alpha, d) ** 2
        + (1 - n_terms / n_estimator)
        * _difference_autocovariance(n_terms / stride, filter_factor, alpha, d) ** 2
        + 2 * np.sum((1 - lags / n_estimator) * inner)
    )


def _white_phase_unmodified_inverse_edf(n_estimator, ratio, d):
    """Case 4 (alpha = 2, unmodified): exact for white phase, whose d-th differences at lag m
    correlate only at separations of whole multiples of m, with coefficient
    (-1)^l C(2d, d+l) / C(2d, d)."""
    terms_reached = math.ceil(ratio)
    lags = np.arange(1, min(d, terms_reached - 1) + 1)
    rho = special.comb(2 * d, d + lags) / special.comb(2 * d, d)
    return (1.0 + 2.0 * np.sum((1 - lags / ratio) * rho**2)) / n_estimator


def _table(table, alpha, d):
    entry = table[alpha][d - 1]
    if entry is None:
        raise ValueError(f"no EDF for noise exponent alpha={alpha} with d={d}")
    return entry


def equivalent_degrees_of_freedom(
    alpha: int,
    d: int,
    m: int,
    n_phase: int,
    *,
    overlapping: bool,
    modified: bool,
    phase_averaged: bool = False,
) -> float:
    """Equivalent degrees of freedom of an Allan-family variance estimate.

    Greenhall & Riley (2003) algorithm: ``alpha`` is the power-law exponent of S_y(f), ``d``
    the difference order (2 Allan, 3 Hadamard), ``m`` the averaging factor, ``n_phase`` the
    number of phase points; ``overlapping`` estimators have stride 1, ``modified`` ones average
    the phase over m points first. Requires alpha + 2d > 1.

    ``phase_averaged`` selects how the phase samples relate to the continuous phase, which
    matters at small m for the unmodified variances: True takes each as the average over its
    sample period (the algorithm's filter F = m while m (d + 1) <= 100, as published and as
    Stable32 uses it); False (the default) takes point samples (F = infinity), which is exact
    for IMU data, whose rate samples average the rate over the period: white rate noise then
    gives white samples, and the EDF equals that of the exact quadratic form (at m = 1 and
    N = 1001, 666 rather than the 782 of the averaged model).

    Parameters
    ----------
    alpha : int
        Power-law exponent of S_y(f) (2 white phase ... -2 random walk of frequency).
    d : int
        Difference order: 2 for the Allan variances, 3 for the Hadamard.
    m : int
        Averaging factor (tau = m / rate).
    n_phase : int
        Number of phase points (samples of the rate plus one).
    overlapping : bool
        Stride 1 (True) or m (False).
    modified : bool
        The modified variance (the phase averaged over m points first).
    phase_averaged : bool
        Phase samples as averages over their period (Stable32) rather than point samples.

    Returns
    -------
    float
        The equivalent degrees of freedom, dimensionless.

    Raises
    ------
    ValueError
        alpha + 2d <= 1 (the variance does not converge for that noise).

    Examples
    --------
    >>> import bayescal as bc
    >>> edf = bc.equivalent_degrees_of_freedom(0, 2, 1, 1001, overlapping=True, modified=False)
    >>> round(edf)
    666
    """
    alpha, d, m = int(alpha), int(d), int(m)
    if alpha + 2 * d <= 1:
        raise ValueError(
            f"noise exponent alpha={alpha} needs a difference order d > {(1 - alpha) / 2}"
        )
    filter_factor = 1 if modified else m
    stride = m if overlapping else 1
    filter_length = m // filter_factor + m * d
    if n_phase < filter_length:
        raise ValueError(f"{n_phase} phase points are too few for m={m}, d={d}")
    n_estimator = 1 + math.floor(stride * (n_phase - filter_length) / m)
    n_terms = min(n_estimator, (d + 1) * stride)
    ratio = n_estimator / stride

    if modified:
        if n_terms <= _J_MAX:
            inverse = _basic_sum(n_terms, n_estimator, stride, 1, alpha, d) / (
                n_estimator * _difference_autocovariance(0.0, 1, alpha, d) ** 2
            )
        elif ratio > d + 1:
            a0, a1 = _table(_TABLE1_MODIFIED, alpha, d)
            inverse = (a0 - a1 / ratio) / ratio
        else:
            inverse = _basic_sum(_J_MAX, _J_MAX, _J_MAX / ratio, 1, alpha, d) / (
                _J_MAX * _difference_autocovariance(0.0, 1, alpha, d) ** 2
            )
    elif alpha <= 0:
        if n_terms <= _J_MAX:
            filt = m if phase_averaged and m * (d + 1) <= _J_MAX else math.inf
            inverse = _basic_sum(n_terms, n_estimator, stride, filt, alpha, d) / (
                n_estimator * _difference_autocovariance(0.0, filt, alpha, d) ** 2
            )
        elif ratio > d + 1:
            a0, a1 = _table(_TABLE2_UNMODIFIED, alpha, d)
            inverse = (a0 - a1 / ratio) / ratio
        else:
            inverse = _basic_sum(_J_MAX, _J_MAX, _J_MAX / ratio, math.inf, alpha, d) / (
                _J_MAX * _difference_autocovariance(0.0, math.inf, alpha, d) ** 2
            )
    elif alpha == 1:
        b0, b1 = _TABLE3_FLICKER_PHASE[d - 1]
        if n_terms <= _J_MAX:
            inverse = _basic_sum(n_terms, n_estimator, stride, m, 1, d) / (
                n_estimator * _difference_autocovariance(0.0, m, 1, d) ** 2
            )
        elif ratio > d + 1:
            a0, a1 = _table(_TABLE2_UNMODIFIED, 1, d)
            inverse = (a0 - a1 / ratio) / ((b0 + b1 * math.log(m)) ** 2 * ratio)
        else:
            m_prime = _J_MAX / ratio
            inverse = _basic_sum(_J_MAX, _J_MAX, m_prime, m_prime, 1, d) / (
                (b0 + b1 * math.log(m)) ** 2 * _J_MAX
            )
    else:
        inverse = _white_phase_unmodified_inverse_edf(n_estimator, ratio, d)
    return float(1.0 / inverse)


def _lag1_autocorrelation(z: np.ndarray) -> float:
    """sum (z_i - m)(z_{i+1} - m) / sum (z_i - m)^2, m the mean, from sums over ``z`` itself
    in one pass each: no centred copy of a 2^17-point series made at every tau and
    difference (the series is detrended, or a difference of one, so its mean is near zero
    and nothing cancels). NumPy's own loop (einsum), not BLAS's dot: handed to BLAS's
    threads, these short products took 14x longer on a busy 2-core machine (the octave taus
    of 2^20 samples: 0.68 s against 0.05 s)."""
    n, mean = z.size, float(z.mean())
    ends = float(z[0] + z[-1])
    lagged = np.einsum("i,i->", z[:-1], z[1:]) - mean * (2 * n * mean - ends) + (n - 1) * mean**2
    return float(lagged / (np.einsum("i,i->", z, z) - n * mean**2))


def _detrend(z: np.ndarray, degree: int) -> np.ndarray:
    index = np.arange(z.size, dtype=float)
    return z - np.polynomial.polynomial.polyval(
        index, np.polynomial.polynomial.polyfit(index, z, degree)
    )


def _lag1_noise_exponent(phase: np.ndarray, m: int, max_differences: int) -> int:
    """Riley & Greenhall (2004): difference the decimated, detrended phase until its lag-1
    autocorrelation r1 gives delta = r1 / (1 + r1) < 0.25; alpha = 2 - round(2 delta) - 2d."""
    z = _detrend(phase[::m][:_LAG1_MAX_POINTS], 2)
    differences = 0
    while True:
        r1 = _lag1_autocorrelation(z)
        delta = r1 / (1.0 + r1)
        if delta < 0.25 or differences >= max_differences:
            return int(2 - round(2 * delta) - 2 * differences)
        z = np.diff(z)
        differences += 1


def _b1_theory(n: int, mu: int) -> float:
    """Expected B1 ratio (standard / Allan variance) of n averages for tau^mu noise
    (SP 1065 eq. 72)."""
    if mu == 0:
        return n * math.log(n) / (2 * (n - 1) * math.log(2))
    return n * (1 - n**mu) / (2 * (n - 1) * (1 - 2.0**mu))


def _rn_theory(m: int, alpha: int) -> float:
    """Expected R(n) = Mod AVAR / AVAR for phase noise (SP 1065 section 5.6.2, f_h = 1/(2 tau0))."""
    if alpha == 2:
        return 1.0 / m
    avar = (1.038 + 3 * math.log(2 * math.pi * 0.5 * m)) / (4 * math.pi**2)
    mvar = 3 * math.log(256 / 27) / (8 * math.pi**2)
    return mvar / avar


def _b1_noise_exponent(phase: np.ndarray, m: int) -> int:
    """SP 1065 section 5.6.2: compare the B1 ratio (and R(n) for phase noise) with theory,
    boundaries at the geometric mean of neighbouring noise types."""
    block_means = np.diff(phase[::m]) / m
    n = block_means.size
    allan = 0.5 * np.mean(np.diff(block_means) ** 2)
    b1 = np.var(block_means, ddof=1) / allan
    mu = -2
    for candidate in (1, 0, -1):
        boundary = math.sqrt(_b1_theory(n, candidate) * _b1_theory(n, candidate - 1))
        if b1 > boundary:
            mu = candidate
            break
    if mu > -2:
        return -mu - 1
    second = phase[2 * m :] - 2 * phase[m:-m] + phase[: -2 * m]
    if second.size <= m:
        return 2  # too short for R(n): phase noise, taken as white
    window = np.concatenate(([0.0], np.cumsum(second)))
    modified = np.mean((window[m:] - window[:-m]) ** 2) / m**2
    ratio = modified / np.mean(second**2)
    boundary = math.sqrt(_rn_theory(m, 2) * _rn_theory(m, 1))
    return 2 if ratio < boundary else 1


def identify_noise_exponent(phase: np.ndarray, m: int, *, max_differences: int = 2) -> int:
    """Dominant power-law exponent alpha of S_y(f) at averaging factor ``m``.

    ``phase`` is the integrated signal (one lane). The lag-1 autocorrelation method is used
    while at least 30 decimated points remain, the B1 / R(n) ratios below that (as Stable32
    does); ``max_differences`` is 2 for Allan and modified Allan, 3 for Hadamard variances.
    The result is clipped to the exponents the estimator's EDF is defined for.

    Parameters
    ----------
    phase : numpy.ndarray
        The integrated signal of one lane (phase points; no missing samples).
    m : int
        Averaging factor.
    max_differences : int
        2 for Allan and modified Allan, 3 for Hadamard.

    Returns
    -------
    int
        alpha: 2 white phase, 1 flicker phase, 0 white rate (frequency), -1 flicker rate,
        -2 random walk of rate (-3, -4 with three differences).
    """
    if (phase.size - 1) // m + 1 >= _LAG1_MIN_POINTS:
        alpha = _lag1_noise_exponent(phase, m, max_differences)
    else:
        alpha = _b1_noise_exponent(phase, m)
    lowest = 2 - 2 * max_differences
    return int(min(2, max(lowest, alpha)))


def _upper_normal_quantile_as26_2_22(p: float, a1: float) -> float:
    """x with Q(x) = p by Abramowitz & Stegun 26.2.22 (|error| < 3e-3)."""
    tail = min(p, 1 - p)
    t = math.sqrt(-2 * math.log(tail))
    x = t - (2.30753 + a1 * t) / (1 + 0.99229 * t + 0.04481 * t * t)
    return x if p <= 0.5 else -x


def chi2_quantile(probability, edf):
    """The chi-square quantile (the inverse regularised lower incomplete gamma function, as
    ``scipy.stats.chi2.ppf`` computes it), from ``scipy.special`` alone: importing
    ``scipy.stats`` costs a classical-only run half a second."""
    return 2.0 * special.gammaincinv(np.asarray(edf, dtype=float) / 2, probability)


def _chi2_quantile_stable32(probability: float, edf: float) -> float:
    """The chi-square quantile as Stable32 1.60 computes it: exact below 101 degrees of
    freedom, above that A&S 26.4.17 with A&S 26.2.22 for the normal quantile — using the
    coefficient 0.27601 where A&S prints 0.27061 (reported by A. Wallin, 2015)."""
    if edf <= 100:
        return float(chi2_quantile(probability, edf))
    x = _upper_normal_quantile_as26_2_22(1 - probability, 0.27601)
    return edf * (1 - 2 / (9 * edf) + x * math.sqrt(2 / (9 * edf))) ** 3


def deviation_interval(deviation, edf, confidence: float, method: str = "exact"):
    """Two-sided interval of a deviation with ``edf`` degrees of freedom (SP 1065 eq. 45).

    Parameters
    ----------
    deviation : array_like
        The deviations (any unit).
    edf : array_like
        Their equivalent degrees of freedom (broadcast against ``deviation``).
    confidence : float
        Two-sided confidence, in (0, 1).
    method : "exact" or "stable32"
        ``"exact"`` uses the chi-square quantiles; ``"stable32"`` reproduces Stable32's
        approximation above 100 degrees of freedom (for comparison with its tables only).

    Returns
    -------
    low, high : numpy.ndarray
        The interval's ends, shaped like ``deviation``, in its unit.

    Raises
    ------
    InputError
        An unknown ``method``; an ``edf`` that does not broadcast against ``deviation``.

    Examples
    --------
    >>> import bayescal as bc
    >>> low, high = bc.deviation_interval(0.01, 100.0, 0.95)
    >>> round(float(low), 5), round(float(high), 5)
    (0.00879, 0.01161)
    """
    deviation = np.asarray(deviation, dtype=float)
    edf = np.asarray(edf, dtype=float)
    try:
        edf = np.broadcast_to(edf, deviation.shape)
    except ValueError:
        raise InputError(
            f"edf has shape {edf.shape} but deviation has {deviation.shape}",
            fix="give one edf per deviation, or one for all",
        ) from None
    tail = (1.0 - confidence) / 2
    if method == "exact":
        chi_low, chi_high = chi2_quantile(tail, edf), chi2_quantile(1 - tail, edf)
    elif method == "stable32":
        quantile = np.vectorize(_chi2_quantile_stable32, otypes=[float])
        chi_low, chi_high = quantile(tail, edf), quantile(1 - tail, edf)
    else:
        raise InputError(f"method={method!r} must be 'exact' or 'stable32'")
    return deviation * np.sqrt(edf / chi_high), deviation * np.sqrt(edf / chi_low)
