"""Built-in example recordings, made by bayescal's own simulator so that every command can be
tried with no data at hand."""

import numpy as np

from ..models._noise_model import NoiseModel
from ..recording._recording import Recording

# A MEMS-grade gyro axis: turn-on bias 0.4 deg/s, angle random walk 0.21 deg/sqrt(h),
# rate random walk 8.6 deg/h/sqrt(h); one hour at 100 Hz.
EXAMPLE_GYRO = NoiseModel(rate_hz=100.0, bias=0.4, N=0.0035, K=4e-5)
EXAMPLE_DURATION_S = 3600.0


def example_recording(seed: int = 0) -> Recording:
    """One hour of a static gyro axis (``gyro_x`` in deg/s) with a ``time`` column."""
    n = int(EXAMPLE_DURATION_S * EXAMPLE_GYRO.rate_hz)
    gyro = EXAMPLE_GYRO.simulate(n, seed=seed)
    time = np.arange(n) / EXAMPLE_GYRO.rate_hz
    source = (
        f"<built-in example, seed {seed}: bias {EXAMPLE_GYRO.bias} deg/s, "
        f"N {EXAMPLE_GYRO.N} deg/s/sqrt(Hz), K {EXAMPLE_GYRO.K} deg/s*sqrt(Hz)>"
    )
    return Recording(source, {"time": time, "gyro_x": gyro}, {"time": "s", "gyro_x": "deg/s"})
