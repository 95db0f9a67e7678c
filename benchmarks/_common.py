"""Shared pieces of the benchmarks: the classical peers, the Cramér-Rao bound, and a
recording reduced to what a fleet's population reads of it.

bayescal is imported inside the functions that need it: the peer pipeline of
``long_recording.py`` imports this module in its own timed process, which must not pay for
JAX.
"""

import math

import numpy as np

FLOOR = math.sqrt(2 * math.log(2) / math.pi)
PARAMETERS = ("N", "B", "K")


def cramer_rao_bound(truth: dict, rate_hz: float, n_samples: int) -> dict:
    """Standard deviations of the Cramér-Rao bound for N, B, K from the Fisher information
    of the exact Gaussian likelihood of the increments, in its asymptotic (Whittle) form:
    F_ab = sum_j dS_j/da dS_j/db / S_j^2 over the Fourier frequencies of n - 1 increments."""
    from bayescal.models.effects.bias_instability import BiasInstability
    from bayescal.models.effects.rate_random_walk import RateRandomWalk
    from bayescal.models.effects.white import White

    length = n_samples - 1
    nu = np.arange(1, (length - 1) // 2 + 1) / length
    terms = {"N": White, "B": BiasInstability, "K": RateRandomWalk}
    basis = {p: np.asarray(term.spectrum(nu, rate_hz)) for p, term in terms.items()}
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


def stand_in_recording(unit: int, run: int, *, bias_mean, bias_sd, log_draws=None, prior=None):
    """A run of unit ``unit`` (``SN00`` ...) reduced to what the fleet's population reads of
    it: its stored draws of the noise scales' logs (``log_draws``, with their fitting prior's
    ``{name: (location, scale)}`` of the log) and its bias's conditional mean and sd at each
    draw, as a 41 s gyro record at 100 Hz would give them."""
    from bayescal.inference._population import RecordingDraws

    log_draws, prior = log_draws or {}, prior or {}
    return RecordingDraws(
        source=f"unit{unit}-run{run}",
        unit=f"SN{unit:02d}",
        run=str(run + 1),
        channel="gyro_x",
        channel_unit="deg/s",
        rate_hz=100.0,
        n_samples=4096,
        terms=("white", *(("rate_random_walk",) if "K" in log_draws else ())),
        log_draws=log_draws,
        prior_location={name: location for name, (location, _) in prior.items()},
        prior_scale={name: scale for name, (_, scale) in prior.items()},
        bias_mean=bias_mean,
        bias_sd=bias_sd,
    )


def fresh_cache_environment(folder) -> dict:
    """This process's environment for a child that runs as on a machine's first run: its
    caches under ``folder`` (``XDG_CACHE_HOME``), and none of the cache folders this process's
    bayescal put in the environment when it loaded JAX (``bayescal._caches.enable_caches``),
    which would hand the child the warm ones."""
    import os

    inherited = ("JAX_COMPILATION_CACHE_DIR", "BAYESCAL_TRACE_CACHE")
    environment = {k: v for k, v in os.environ.items() if k not in inherited}
    environment["XDG_CACHE_HOME"] = str(folder)
    return environment
