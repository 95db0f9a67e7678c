"""Real recordings with temperature: what thermal slope (if any) do the data support?

    python benchmarks/thermal_real.py

MPU-6050 (sunsided sensor-fusion, set-2, 10 min unmoved, temperature 25.1-25.6 degC; the time
stamps are irregular, so the samples are taken as evenly spaced at their mean rate) and
ADIS16405 (PSAS Launch-11 drop-test baselines, 70 s each, temperature within about 0.4 degC).
For each gyro axis: the degree the one-block-ahead ELPD chooses, and the linear coefficient
with its 90 % interval — with the temperature range it rests on, since a slope over half a
degree says nothing about the bias 10 degrees away.
"""

from pathlib import Path

import h5py
import numpy as np

import bayescal as bc
from bayescal.inference._priors import default_prior
from bayescal.inference._thermal_posterior import choose_degree
from bayescal.models._thermal import ThermalRecord

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
TERMS = ("white", "bias_instability", "rate_random_walk")


def mpu6050():
    folder = SHARED / "sunsided_mpu6050/data/set-2/unmoved-with-x-pointing-forward-10min"
    gyro = h5py.File(folder / "mpu6050_gyroscope.mat")["gyroBuffer"][()].T
    temperature = h5py.File(folder / "mpu6050_temperature.mat")["temperatureBuffer"][()].T
    rate = (gyro.shape[0] - 1) / (gyro[-1, 0] - gyro[0, 0])
    for axis, name in enumerate(("gyro_x", "gyro_y", "gyro_z"), start=1):
        yield "MPU-6050 set-2 10 min", name, gyro[:, axis], temperature[:, 1], rate


def adis16405():
    for run in ("Launch-11_droptest_baseline-0", "Launch-11_droptest_baseline-1"):
        recording = bc.load_recording(
            SHARED / "psas_adis16405" / run / "logfile-000_ADIS_decoded.csv"
        )
        for name in ("gyro_x_dps", "gyro_y_dps", "gyro_z_dps"):
            data = recording.channel(name, gaps="split", temperature="temp_C")
            yield f"ADIS16405 {run[-10:]}", name, data.values, data.temperature, data.rate_hz


def main() -> None:
    print("thermal slope supported by real recordings (deg/s per degC, 90 % interval)")
    for label, channel, values, temperature, rate in (*mpu6050(), *adis16405()):
        present = temperature[~np.isnan(temperature)]
        reference = float(np.round(np.mean(present), 1))
        # The degree alone (fit_thermal(degree="auto") would also sample the chosen one).
        record = ThermalRecord(values, temperature, rate, ((0, values.size),))
        prior = default_prior(TERMS, bc.allan_deviation(values, rate))
        degree, _scores = choose_degree(record, reference, noise_prior=prior)
        fit = bc.fit_thermal(
            values,
            temperature,
            rate,
            degree=1,
            reference=reference,
            terms=TERMS,
            unit="deg/s",
            channel=channel,
            seed=0,
        )
        slope = fit.posterior.coefficient_draws[:, 1]
        low, high = np.quantile(slope, [0.05, 0.95])
        span = float(np.ptp(present))
        verdict = "no thermal slope supported" if degree == 0 else f"degree {degree} supported"
        print(
            f"  {label:<24}{channel:<11} range {span:.2f} degC; ELPD picks degree {degree} "
            f"({verdict}); linear slope {np.mean(slope):+.4f} [{low:+.4f}, {high:+.4f}]; "
            f"over the range {np.mean(slope) * span:+.4f} deg/s; checks "
            f"{'ok' if fit.passed else 'FAILED'}"
        )


if __name__ == "__main__":
    main()
