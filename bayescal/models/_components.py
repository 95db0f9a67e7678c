"""The spectral components of the stationary noise model: one per noise term, in a fixed
order that every likelihood and covariance of bayescal shares.

Each component is a fixed shape times a weight (:func:`component_weights`); the output filter
splits the white noise into a lag-zero and a lag-one part, so that N keeps its meaning.
"""

import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from .effects.bias_instability import BiasInstability
from .effects.output_filter import OutputFilter
from .effects.quantization import Quantization
from .effects.rate_random_walk import RateRandomWalk
from .effects.white import White

SPECTRAL_TERMS = (White, OutputFilter, BiasInstability, RateRandomWalk, Quantization)
"""The terms with a component of stationary increments, in the order of the components."""
SPECTRAL_COMPONENTS = tuple(term.name for term in SPECTRAL_TERMS)


def component_weights(N=0.0, B=0.0, K=0.0, Q=0.0, F=0.0):
    """Weights of :data:`SPECTRAL_COMPONENTS` for the given parameters (arrays broadcast,
    the components on the last axis)."""
    # The filter's taps once, for the two components it splits white noise into.
    taps = OutputFilter.taps(F)
    weights = (
        White.weight(N, taps),
        OutputFilter.weight(N, taps),
        BiasInstability.weight(B),
        RateRandomWalk.weight(K),
        Quantization.weight(Q),
    )
    return jnp.stack(jnp.broadcast_arrays(*weights), axis=-1)


def increment_spectrum_shapes(nu, rate_hz) -> dict:
    """Two-sided spectra of the sample increments d_k = y_{k+1} - y_k per unit weight of each
    component, at ``nu`` cycles per sample (0 < nu <= 1/2)."""
    return {term.name: term.spectrum(nu, rate_hz) for term in SPECTRAL_TERMS}


def increment_autocovariance_shapes(lags, rate_hz) -> dict:
    """Autocovariances of the increments at integer ``lags`` per unit weight of each component
    (NumPy): the Fourier pairs of :func:`increment_spectrum_shapes`."""
    lags = np.abs(np.asarray(lags, dtype=float))
    return {term.name: term.autocovariance(lags, rate_hz) for term in SPECTRAL_TERMS}


def block_covariance_basis(start: np.ndarray, stop: np.ndarray, rate_hz: float) -> np.ndarray:
    """(components, blocks, blocks): covariance of the means of samples [start, stop) per unit
    weight of each component, the nonstationary terms started at sample 0."""
    return np.stack([term.block_covariance(start, stop, rate_hz) for term in SPECTRAL_TERMS])
