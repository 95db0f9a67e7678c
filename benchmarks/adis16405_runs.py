"""Real data: N, B and K of six ADIS16405 units (SMAC-Group imudata, 6 static runs of
1,000,000 samples at 100 Hz, gyro in deg/s and accelerometer in g), each with its 90 %
interval, beside the IEEE 952 readings of the Allan variance the R package avar publishes for
run 1 (../shared/data/smac_avar_reference/adis_av.rda).

    python benchmarks/adis16405_runs.py [--runs 1,2,3,4,5,6] [--terms all]

The data are licensed CC BY-NC-SA 4.0 and are read in place from ../shared/data.
"""

import argparse
import time
from pathlib import Path

import numpy as np

import bayescal as bc
from bayescal.classical._noise import slope_readings
from bayescal.models._terms import display_values, parse_terms

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
CHANNELS = (
    ("gyro_x", "deg/s"),
    ("gyro_y", "deg/s"),
    ("gyro_z", "deg/s"),
    ("acc_x", "g"),
    ("acc_y", "g"),
    ("acc_z", "g"),
)
RATE = 100.0


def published_readings() -> dict:
    """IEEE 952 readings of the published Allan variance of run 1, per channel."""
    import rdata

    published = rdata.read_rda(str(SHARED / "smac_avar_reference/adis_av.rda"))["adis_av"]
    readings = {}
    for (channel, _), name in zip(CHANNELS, published["avar"], strict=True):
        entry = published["avar"][name]
        tau = np.asarray(entry["levels"], dtype=float)
        deviation = np.sqrt(np.asarray(entry["allan"], dtype=float))
        low = (
            deviation
            * np.asarray(entry["lci"], dtype=float)
            / np.asarray(entry["adev"], dtype=float)
        )
        high = (
            deviation
            * np.asarray(entry["uci"], dtype=float)
            / np.asarray(entry["adev"], dtype=float)
        )
        curve = bc.DeviationResult(
            tau=tau,
            m=np.round(tau * RATE),
            deviation=deviation,
            ci_low=low,
            ci_high=high,
            n=np.zeros(tau.size),
            edf=np.zeros(tau.size),
            alpha=np.zeros(tau.size),
            confidence=0.95,
            estimator="oadev",
        )
        readings[channel] = slope_readings(curve)
    return readings


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", default="1,2,3,4,5,6")
    parser.add_argument("--terms", default="white,bias_instability,rate_random_walk")
    args = parser.parse_args()
    terms = parse_terms(args.terms)
    counts = np.load(SHARED / "smac_imudata_adis16405/adis_16405_imu1-6_counts.npz")
    scale = np.array([float(counts["gyro_lsb_dps"])] * 3 + [float(counts["acc_lsb_g"])] * 3)
    published = published_readings()

    print(f"ADIS16405, SMAC imudata runs {args.runs}, model: bias + {', '.join(terms)}")
    print("  published avar (run 1), IEEE 952 readings:")
    for channel, unit in CHANNELS:
        shown = ", ".join(
            f"{p} {'<= ' if r.kind == 'upper_bound' else ''}"
            f"{(r.ci_high if r.kind == 'upper_bound' else r.value):.3g}"
            for p, r in published[channel].items()
        )
        print(f"    {channel:<7} {shown}  ({unit} based units)")
    for run in (int(r) for r in args.runs.split(",")):
        data = counts[f"imu{run}_counts"].astype(float) * scale
        for index, (channel, unit) in enumerate(CHANNELS):
            values = data[:, index]
            start = time.perf_counter()
            fit = bc.fit_noise(values, RATE, terms=terms, unit=unit, channel=channel, seed=run)
            elapsed = time.perf_counter() - start
            parts = []
            for name in ("N", "B", "K", "Q", "R"):
                if name not in fit.parameters:
                    continue
                summary = fit.summary[name]
                display = display_values(name, summary["mean"], unit)
                label, factor = (
                    next(iter(display.items())) if display else (summary["unit"], summary["mean"])
                )
                ratio = factor / summary["mean"]
                parts.append(
                    f"{name} {summary['mean'] * ratio:.3g} [{summary['q05'] * ratio:.3g}, "
                    f"{summary['q95'] * ratio:.3g}] {label}"
                )
            checks = "ok" if fit.passed else "FAILED " + "; ".join(fit.failures)
            print(
                f"  run {run} {channel:<7} "
                + "; ".join(parts)
                + f"  ({elapsed:.0f} s, checks {checks})"
            )


if __name__ == "__main__":
    main()
