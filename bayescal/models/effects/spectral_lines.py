"""Spectral lines: sinusoids at fixed frequencies in the noise (vibration, a fan, a rotor, a
converter's own clock, mains pickup), DESIGN.md's f_k, A_k."""

import math
from typing import ClassVar

import jax
import jax.numpy as jnp
import numpy as np

from ... import _x64  # noqa: F401  (float64 before any JAX array)
from ...classical._lines import find_lines
from ._base import NoiseTerm
from ._parameter import Parameter


class SpectralLines(NoiseTerm):
    """Lines A_k sin(2 pi f_k t + phi_k) over the noise, found in the record by a periodogram
    test corrected for the number of frequencies looked at
    (:func:`~bayescal.classical._lines.find_lines`): a term *found in the record*
    (:attr:`~bayescal.models.effects._base.NoiseTerm.found_in_record`). Each line's
    frequency and amplitude (a broadened line's power and width) are estimated there; the
    record less the lines (a broadened line's band left out) is what the stochastic terms
    are fitted to, so that N is the floor between the lines and not lifted by them. Allan
    variance A^2 [sin^2(pi f tau) / (pi f tau)]^2 per line (DESIGN.md); deterministic, a
    line adds nothing to the noise's spectrum (:meth:`~bayescal.NoiseModel.psd`) or its
    likelihood. In a :class:`~bayescal.NoiseModel` the lines are ``line_amplitude`` (as the
    samples show it, peak) and ``line_frequency``, one entry per line; each is simulated with
    a phase drawn uniformly from its own stream."""

    name: ClassVar[str] = "spectral_lines"
    explanation: ClassVar[str] = (
        "Periodic disturbances (vibration, fans, rotors, a converter's clock, mains pickup) "
        "add lines to the spectrum at fixed frequencies, above the noise floor between them."
    )
    located_by: ClassVar[str] = "spectral_line"
    band: ClassVar[str] = "line"
    aliases: ClassVar[tuple[str, ...]] = ("lines", "line", "spectral_line")
    parameters: ClassVar[tuple[Parameter, ...]] = (
        Parameter("line_amplitude", "amplitude of a spectral line in the samples (peak)"),
        Parameter("line_frequency", "frequency of a spectral line", time_power=None, unit="Hz"),
    )
    found_in_record: ClassVar[bool] = True
    streams: ClassVar[tuple[int, ...]] = (6,)

    @classmethod
    def find(cls, values, rate_hz: float, transform=None):
        """The record's lines (:func:`~bayescal.classical._lines.find_lines`; its periodogram
        from ``transform`` where given)."""
        return find_lines(values, rate_hz, transform=transform)

    @classmethod
    def allan_variance(cls, tau, values, rate_hz):
        """sum_k (A_k / sinc(f_k / fs))^2 [sin^2(pi f_k tau) / (pi f_k tau)]^2: DESIGN.md's,
        its A the amplitude of the rate whose period averages the samples are (a line of
        amplitude A_k in the samples), exact at tau = m / fs."""
        tau = jnp.asarray(tau, dtype=float)[..., None]
        frequency = jnp.asarray(values["line_frequency"], dtype=float)
        rate_amplitude = jnp.asarray(values["line_amplitude"], dtype=float) / jnp.sinc(
            frequency / rate_hz
        )
        x = jnp.pi * frequency * tau
        return jnp.sum(rate_amplitude**2 * (jnp.sin(x) ** 2 / x) ** 2, axis=-1)

    @classmethod
    def increment_autocovariance(cls, lags, values, rate_hz):
        """sum_k 2 A_k^2 sin^2(pi nu_k) cos(2 pi nu_k lag), nu_k = f_k / fs: the increments'
        autocovariance of lines of random phase (numpy)."""
        lags = np.asarray(lags, dtype=float)
        nu = np.atleast_1d(np.asarray(values["line_frequency"], dtype=float)) / rate_hz
        amplitude = np.atleast_1d(np.asarray(values["line_amplitude"], dtype=float))
        weight = 2 * amplitude**2 * np.sin(np.pi * nu) ** 2
        return np.sum(weight * np.cos(2 * np.pi * nu * lags[..., None]), axis=-1)

    @classmethod
    def sample(cls, keys, n, rate_hz, values):
        """Each line A sin(2 pi f (k + 1/2) / fs + phi) at sample k, its phase uniform in
        [0, 2 pi): the period averages of a rate of amplitude A / sinc(f / fs)."""
        frequency = jnp.atleast_1d(jnp.asarray(values["line_frequency"], dtype=float))
        amplitude = jnp.atleast_1d(jnp.asarray(values["line_amplitude"], dtype=float))
        phase = jax.random.uniform(keys[cls.streams[0]], frequency.shape) * 2 * math.pi
        middle = (jnp.arange(n)[:, None] + 0.5) * (frequency / rate_hz)[None, :]
        return jnp.sum(amplitude * jnp.sin(2 * jnp.pi * middle + phase), axis=-1)
