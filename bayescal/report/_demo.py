"""``bayescal demo`` written out: the simulated 6-axis recording
(:mod:`bayescal.capabilities._demo`) as CSV beside its truth, analysed into the report, with
discovery on every gyro."""

from dataclasses import replace
from pathlib import Path

from .._output import staged, write_csv, write_json
from ..capabilities._demo import DEMO_CHANNELS, DEMO_SENSOR, DISCOVERY_BASELINE, demo_recording
from ..inference._sampler import Sampler
from ..recording._recording import load_recording
from ._discovery import discover_channel
from ._report import ReportOutcome, report_recording


def write_demo(
    folder, *, seed: int = 0, minutes: float = 25.0, progress: bool = False
) -> tuple[Path, ReportOutcome]:
    """Simulate the demo IMU, write ``demo_imu.csv`` and ``demo_truth.json`` into ``folder``
    and its report beside them; the recording's path and the report's outcome."""
    folder = Path(folder)
    folder.mkdir(exist_ok=True)
    columns, truth = demo_recording(seed, minutes)
    csv_path = folder / "demo_imu.csv"
    write_csv(csv_path, columns)
    write_json(folder / "demo_truth.json", truth)
    # Read back as a user's file is read (before the run ends, from its staged temporary).
    recording = replace(load_recording(staged(csv_path)), source=str(csv_path))

    def discoveries(recording, channel):
        """Discovery on every gyro: the hidden effect must be found where it is, and nothing
        where nothing is."""
        if not channel.channel.startswith("gyro"):
            return None
        return discover_channel(recording, channel, seed=seed, baseline=DISCOVERY_BASELINE)

    outcome = report_recording(
        recording,
        list(DEMO_CHANNELS),
        folder,
        stem="demo_imu",
        title="bayescal demo: simulated 6-axis MEMS IMU (MPU-6050 class), 100 Hz",
        sensor=DEMO_SENSOR,
        seed=seed,
        discoveries=discoveries,
        sampler=Sampler(progress=progress),
    )
    return csv_path, outcome
