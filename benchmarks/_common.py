"""Shared pieces of the noise benchmarks: the classical peers and the Cramér-Rao bound."""

import math

import numpy as np

from bayescal.models._components import increment_spectrum_shapes

FLOOR = math.sqrt(2 * math.log(2) / math.pi)
PARAMETERS = ("N", "B", "K")


def cramer_rao_bound(truth: dict, rate_hz: float, n_samples: int) -> dict:
    """Standard deviations of the Cramér-Rao bound for N, B, K from the Fisher information
    of the exact Gaussian likelihood of the increments, in its asymptotic (Whittle) form:
    F_ab = sum_j dS_j/da dS_j/db / S_j^2 over the Fourier frequencies of n - 1 increments."""
    length = n_samples - 1
    nu = np.arange(1, (length - 1) // 2 + 1) / length
    shapes = {
        key: np.asarray(value) for key, value in increment_spectrum_shapes(nu, rate_hz).items()
    }
    basis = {"N": shapes["white"], "B": shapes["bias_instability"], "K": shapes["rate_random_walk"]}
    spectrum = sum(truth[p] ** 2 * basis[p] for p in PARAMETERS)
    gradient = np.array([2 * truth[p] * basis[p] / spectrum for p in PARAMETERS])
    fisher = gradient @ gradient.T
    bound = np.sqrt(np.diag(np.linalg.inv(fisher)))
    return dict(zip(PARAMETERS, bound, strict=True))


def allan_wls_fit(values: np.ndarray, rate_hz: float) -> dict:
    """The classical fit: overlapping Allan variance by allantools at octave taus, then
    weighted least squares of N^2/tau + (2 ln 2 / pi) B^2 + K^2 tau / 3 on it (non-negative),
    each point weighted by the inverse variance of an AVAR estimate with the white-noise EDF
    (NIST SP 1065 Table 5)."""
    import allantools
    from scipy.optimize import nnls

    top = len(values) // 4
    taus = 2.0 ** np.arange(int(math.log2(top)) + 1) / rate_hz
    tau, deviation, _, _ = allantools.oadev(values, rate=rate_hz, data_type="freq", taus=taus)
    variance = deviation**2
    m = tau * rate_hz
    n = len(values) + 1
    edf = ((3 * (n - 1) / (2 * m)) - (2 * (n - 2) / n)) * (4 * m**2 / (4 * m**2 + 5))
    weight = np.sqrt(edf / 2) / variance
    design = np.column_stack([1 / tau, np.full_like(tau, FLOOR**2), tau / 3]) * weight[:, None]
    squares, _ = nnls(design, variance * weight)
    return dict(zip(PARAMETERS, np.sqrt(squares), strict=True))
