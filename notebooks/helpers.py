"""What the study notebooks share: where the data are, and a temporary folder for what a
notebook writes.

The notebooks run with ``notebooks/`` as their working directory; the real recordings live in
``../shared/data`` beside the repository and are read in place, never copied.
"""

import atexit
import shutil
import tempfile
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parent.parent
DATA = REPOSITORY.parent / "shared" / "data"


def work_folder(name: str) -> Path:
    """A fresh temporary folder for what a notebook writes (a calibration file, say), removed
    when the kernel exits."""
    folder = Path(tempfile.mkdtemp(prefix=f"bayescal-{name}-"))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    return folder


PER_HOUR = 1 / 3600
"""deg/s per deg/h."""
GYROS = ("gyro_x", "gyro_y", "gyro_z")
CHAMBER = {
    "gyro_x": (0.05, 0.003, 5e-5),
    "gyro_y": (-0.04, -0.002, 4e-5),
    "gyro_z": (0.03, 0.001, -3e-5),
}
"""The chamber truth of each gyro: bias(T) = c0 + c1 (T - 30) + c2 (T - 30)^2, deg/h per degC^j."""
CHAMBER_NOISE = {"N": 0.002 / 60, "B": 0.0005 * PER_HOUR}
"""Navigation grade: angle random walk 0.002 deg/sqrt(h), bias instability 0.0005 deg/h."""


def chamber_calibrations(folder: Path) -> dict:
    """The chamber calibration of a navigation-grade IMU's three gyros, as the in-field
    notebooks start from it: three hours on a still table (the Earth rate nulled) while the
    chamber sweeps 15 -> 45 degC, sampled at 2 Hz, each gyro fitted as ``bayescal thermal fit``
    does (a quadratic about 30 degC), joined into one file in ``folder`` and read back."""
    import numpy as np

    import bayescal as bc

    rate = 2.0
    n = int(3 * 3600 * rate)
    chamber_temperature = 15 + 30 * (1 - np.exp(-np.arange(n) / rate / 3000))
    powers = (chamber_temperature[:, None] - 30) ** np.arange(3)
    calibrations = []
    for index, name in enumerate(GYROS):
        noise = bc.NoiseModel(rate_hz=rate, **CHAMBER_NOISE).simulate(n, seed=100 + index)
        calibration = bc.fit_thermal(
            powers @ (np.array(CHAMBER[name]) * PER_HOUR) + noise,
            chamber_temperature,
            rate,
            degree=2,
            reference=30.0,
            terms="white,bias_instability",
            channel=name,
            seed=index,
        ).check()
        calibrations.append(calibration)
    path = bc.save_thermal_calibrations(calibrations, folder / "old.json")
    return {name: bc.load_thermal_calibration(path, channel=name) for name in GYROS}
