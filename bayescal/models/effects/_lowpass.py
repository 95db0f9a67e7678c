"""What the output filter's low-pass shapes share: they shape the white noise by their |H|^2,
with unit gain at zero frequency, so that N stays the low-frequency density the Allan curve
reads (IEEE Std 952) whatever the filter does near Nyquist.

A shape multiplies the white noise's spectrum (the expected periodogram at each bin's nodes,
:func:`bayescal.models._whittle.node_spectrum`): exact where the shape varies slowly over the
taper's spectral window (a few Fourier frequencies), which it does. A rounding floor (the
samples' LSB, :mod:`.quantization`) comes after the filter and is not shaped.
"""

from typing import ClassVar

import jax.numpy as jnp
import numpy as np

from ... import _x64  # noqa: F401  (float64 before any JAX array)
from ._base import NoiseTerm

LOWPASS_EXPLANATION = (
    "The sensor low-pass filters its output before decimating: the white noise is "
    "smoothed, its spectrum falls toward the Nyquist frequency and neighbouring samples "
    "are positively correlated."
)


class LowpassShape(NoiseTerm):
    """A low-pass shape of the output filter (abstract): its :meth:`gain` from its parameters
    by name."""

    explanation: ClassVar[str] = LOWPASS_EXPLANATION
    located_by: ClassVar[str] = "spectrum_bands"
    band: ClassVar[str] = "high"

    @classmethod
    def apply(cls, samples, values: dict, rate_hz: float):
        """``samples`` (JAX, last axis time) through the low-pass, zero phase: each Fourier
        coefficient times sqrt|H|^2. Circular: pass a record twice the length needed and keep
        the first half, so that no sample is filtered with the record's other end."""
        length = samples.shape[-1]
        nu = jnp.maximum(jnp.fft.rfftfreq(length), 1e-12)  # the gain is 1 at zero frequency
        shaped = jnp.fft.rfft(samples, axis=-1) * jnp.sqrt(cls.gain(nu, values, rate_hz))
        return jnp.fft.irfft(shaped, length, axis=-1)

    @classmethod
    def shaped_allan_variance(cls, tau, values: dict, rate_hz: float):
        """The Allan variance of white noise of density N through the low-pass: N^2 fs times
        the integral of |H|^2 against the Allan filter 2 sin^4(pi m nu) / (m^2 sin^2(pi nu))
        (m = tau fs), which is N^2 / tau without the filter; numerically, the oscillating
        kernel replaced by its mean 3 / (4 m^2 sin^2(pi nu)) where the gain falls (beyond 64
        samples an average spans many of its periods, above nu = 1 / (2 m))."""
        N = values["N"]
        nu = (np.arange(1, 8193) - 0.5) / 16384  # midpoints on (0, 1/2)
        loss = 1.0 - np.asarray(cls.gain(nu, values, rate_hz))
        m = np.atleast_1d(np.asarray(tau, dtype=float) * rate_hz)
        sin2 = np.sin(np.pi * nu) ** 2
        exact = 2 * np.sin(np.pi * np.outer(m, nu)) ** 4 / (m[:, None] ** 2 * sin2)
        averaged = 3.0 / (4.0 * m[:, None] ** 2 * sin2)
        # Below nu = 1 / (2 m) the kernel does not oscillate (and its mean would overstate it).
        oscillating = (m[:, None] > 64) & (np.outer(m, nu) > 0.5)
        kernel = np.where(oscillating, averaged, exact)
        # Both halves of the band: twice the integral over (0, 1/2).
        lost = 2 * np.sum(loss * kernel, axis=1) / 16384
        return (N**2 / m - N**2 * lost) * rate_hz
