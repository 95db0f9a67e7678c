"""Equivalent degrees of freedom: against allantools' independent implementation of the same
Greenhall & Riley (2003) algorithm (the phase-averaged variant both publish), against the
exact quadratic-form EDF of white rate noise (the point-sampled variant bayescal uses), and
against Monte Carlo."""

import numpy as np
import pytest

import bayescal as bc

allantools = pytest.importorskip("allantools")


@pytest.mark.parametrize(
    ("d", "overlapping", "modified"),
    [(2, False, False), (2, True, False), (2, True, True), (3, False, False), (3, True, False)],
)
def test_matches_allantools(d, overlapping, modified):
    compared = 0
    for alpha in range(2, 1 - 2 * d, -1):
        if modified and d == 3:
            continue
        for m in (1, 2, 3, 8, 33, 100, 1000):
            for n_phase in (m * (d + 2) + 5, 1001, 19983, 1_000_001):
                if n_phase < m * (d + 1) + 1:
                    continue
                try:
                    expected = allantools.edf_greenhall(
                        alpha=alpha, d=d, m=m, N=n_phase, overlapping=overlapping, modified=modified
                    )
                except (NotImplementedError, IndexError, ZeroDivisionError, AssertionError):
                    continue  # cases allantools does not cover (white phase, alpha = -4 ...)
                ours = bc.equivalent_degrees_of_freedom(
                    alpha,
                    d,
                    m,
                    n_phase,
                    overlapping=overlapping,
                    modified=modified,
                    phase_averaged=True,
                )
                assert ours == pytest.approx(expected, rel=1e-12), (alpha, m, n_phase)
                compared += 1
    assert compared > 50


def _exact_white_rate_edf(n_phase, m, overlapping):
    """(sum of variances)^2 / (sum of squared covariances) of the second differences, whose
    rate-domain filter is m samples of -1 then m of +1."""
    haar = np.concatenate((-np.ones(m), np.ones(m)))
    autocovariance = np.correlate(haar, haar, "full")[haar.size - 1 :]
    stride = 1 if overlapping else m
    terms = (n_phase - 1 - 2 * m) // stride + 1
    lags = np.abs(np.subtract.outer(np.arange(terms), np.arange(terms))) * stride
    covariance = np.where(
        lags < autocovariance.size, autocovariance[np.minimum(lags, autocovariance.size - 1)], 0.0
    )
    return np.trace(covariance) ** 2 / np.sum(covariance**2)


@pytest.mark.parametrize("overlapping", [True, False])
@pytest.mark.parametrize(("n_phase", "m"), [(1001, 1), (1001, 2), (1001, 8), (1001, 32), (300, 20)])
def test_point_sampled_edf_is_exact_for_white_rate_noise(overlapping, n_phase, m):
    expected = _exact_white_rate_edf(n_phase, m, overlapping)
    ours = bc.equivalent_degrees_of_freedom(
        0, 2, m, n_phase, overlapping=overlapping, modified=False
    )
    assert ours == pytest.approx(expected, rel=1e-9)


def _monte_carlo_edf(phase_batch, estimator, m):
    """edf = 2 E[var]^2 / Var(var) over independent realisations."""
    variance = (
        estimator(phase_batch, 1.0, [float(m)], kind="phase", noise_type=0).deviation[:, 0] ** 2
    )
    return 2 * variance.mean() ** 2 / variance.var(ddof=1), variance.size


@pytest.mark.parametrize(
    ("alpha", "overlapping", "n_phase", "m"),
    [(2, False, 9, 3), (2, True, 9, 3), (2, False, 7, 2), (0, True, 200, 8), (-2, True, 400, 16)],
)
def test_matches_monte_carlo(alpha, overlapping, n_phase, m):
    """White phase (alpha 2) with so few terms that allantools has no formula, and two cases
    with correlated noise; the Monte Carlo edf has a relative sd of about sqrt(8/R)."""
    rng = np.random.default_rng(20261122)
    realisations = 20000
    white = rng.standard_normal((realisations, n_phase))
    phase = {
        2: white,
        0: np.cumsum(white, axis=1),
        -2: np.cumsum(np.cumsum(white, axis=1), axis=1),
    }[alpha]
    estimator = lambda *a, **k: bc.allan_deviation(*a, overlapping=overlapping, **k)  # noqa: E731
    simulated, count = _monte_carlo_edf(phase, estimator, m)
    expected = bc.equivalent_degrees_of_freedom(
        alpha, 2, m, n_phase, overlapping=overlapping, modified=False
    )
    # Greenhall's algorithm is exact for these cases but for its table approximations.
    assert simulated == pytest.approx(expected, rel=5 * np.sqrt(8 / count))


def test_identifies_power_law_noise():
    rng = np.random.default_rng(7)
    white = rng.standard_normal(2**14)
    cases = {0: white, -2: np.cumsum(white), 2: np.diff(rng.standard_normal(2**14 + 1))}
    for alpha, rate in cases.items():
        phase = np.concatenate(([0.0], np.cumsum(rate)))
        for m in (1, 4, 16):
            assert bc.identify_noise_exponent(phase, m) == alpha
