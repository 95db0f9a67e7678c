"""The demo's hidden-effect channel over many seeds: does its story hold?

``bayescal demo`` hides a thermal bias in gyro_z (0.002 deg/s/degC, :mod:`bayescal.capabilities.
_demo`). For each seed this runs what the demo runs on gyro_z — the noise fit of the report
(terms chosen by evidence, the MPU-6050 card as prior), discovery from the demo's baseline
(white noise and bias instability), and the noise of the model that holds what discovery found
(:func:`bayescal.report._html.with_effects`) — on the demo's simulated 25-minute recording, and
prints:

- how often discovery names thermal_bias;
- the coverage of discovery's thermal slope c1 (its final model's 90 % interval), with the
  mean and sd of (mean - truth) / sd: whether the slope is low on average or its interval too
  narrow;
- the coverage of N, B, K and c1 in the model with the effect (the numbers the summary shows),
  for seeds 0-9 (the done-when of issue 39) and for all;
- what the noise model without the effect read for K (the contaminated number), as a ratio to
  the truth.

Usage: python benchmarks/demo_story.py --seeds 0-49 --out demo_story.jsonl (one JSON line per
seed, appended; seeds already in the file are not run again; minutes per seed on a loaded
machine).

``--least-squares`` instead prints, in seconds a seed, the ordinary least-squares slope of each
gyro on the recorded temperature (with an intercept): the spread of the simplest unbiased
estimator of c1 over seeds (the noise's own, on gyro_x and gyro_y, whose truth is 0), and where
each seed's record puts it — whether a low c1 is discovery's or the record's.
"""

import argparse
import json
import math
import tempfile
import time
from pathlib import Path

import numpy as np


def _seeds(text: str) -> list[int]:
    if "-" in text:
        first, last = text.split("-")
        return list(range(int(first), int(last) + 1))
    return [int(part) for part in text.split(",")]


def run_seed(seed: int, minutes: float) -> dict:
    """The demo's gyro_z story for one seed: what each model said of c1, N, B and K."""
    from bayescal._output import write_csv
    from bayescal.capabilities._demo import DEMO_SENSOR, DISCOVERY_BASELINE, demo_recording
    from bayescal.models._terms import parse_terms
    from bayescal.recording._recording import load_recording
    from bayescal.recording._sensor_cards import find_card
    from bayescal.report._discovery import discover_channel
    from bayescal.report._html import with_effects
    from bayescal.report._report import analyse_channel

    start = time.time()
    columns, truth = demo_recording(seed, minutes)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "demo_imu.csv"
        write_csv(path, columns)
        recording = load_recording(path)
    data = recording.channel("gyro_z")
    card = find_card(DEMO_SENSOR)
    analysis = analyse_channel(data, terms=parse_terms("auto"), card=card, seed=seed)
    findings = discover_channel(recording, data, seed=seed, baseline=DISCOVERY_BASELINE)
    told = with_effects(analysis, findings, seed=seed, card=card)
    discovery = findings.discovery
    out = {
        "seed": seed,
        "seconds": round(time.time() - start, 1),
        "effects": [effect.name for effect in discovery.effects],
        "noise_terms": list(analysis.noise.noise.terms),
        "noise": {
            name: [s.mean, s.q05, s.q95] for name, s in analysis.noise.noise.parameters.items()
        },
    }
    thermal = next((e for e in discovery.effects if e.name == "thermal_bias"), None)
    if thermal is not None and "c1" in thermal.parameters:
        c1 = thermal.parameters["c1"]
        out["discovery_c1"] = [c1["mean"], c1["q05"], c1["q95"], c1["sd"]]
    if told.effects is not None:
        out["with_effects"] = {
            name: [entry["mean"], entry["q05"], entry["q95"], entry["sd"]]
            for name, entry in told.effects.parameters.items()
        }
        out["with_effects_terms"] = list(told.effects.terms)
        out["with_effects_passed"] = told.effects.passed
    out["truth"] = {
        "c1": truth["hidden_effect"]["c1"]["value"],
        **{p: truth["channels"]["gyro_z"][p]["value"] for p in ("N", "B", "K")},
    }
    return out


def _covered(rows, key, name, truth_of) -> tuple[int, int]:
    inside = [
        row[key][name][1] <= truth_of(row) <= row[key][name][2]
        for row in rows
        if key in row and name in row[key]
    ]
    return sum(inside), len(inside)


def _share(count: int, total: int) -> str:
    return f"{count}/{total} ({100 * count / total:.0f} %)" if total else "n/a"


def summarise(rows: list[dict]) -> None:
    rows = sorted(rows, key=lambda row: row["seed"])
    found = [row for row in rows if "thermal_bias" in row["effects"]]
    print(f"seeds {rows[0]['seed']}-{rows[-1]['seed']} ({len(rows)}), 25-minute demo, gyro_z")
    print(f"  discovery named thermal_bias: {_share(len(found), len(rows))}")
    slopes = [row for row in found if "discovery_c1" in row]
    if slopes:
        truth = slopes[0]["truth"]["c1"]
        z = np.array([(row["discovery_c1"][0] - truth) / row["discovery_c1"][3] for row in slopes])
        inside = sum(row["discovery_c1"][1] <= truth <= row["discovery_c1"][2] for row in slopes)
        low = sum(row["discovery_c1"][2] < truth for row in slopes)
        error = z.std(ddof=1) / math.sqrt(z.size)
        high = sum(row["discovery_c1"][1] > truth for row in slopes)
        print(
            f"  discovery's c1 (its final model), 90 % interval holds {truth:g} deg/s/degC: "
            f"{_share(inside, len(slopes))}; misses low {low}, high {high}; "
            f"(mean - truth) / sd: mean {z.mean():+.2f} (se {error:.2f}), "
            f"sd {z.std(ddof=1):.2f}; means below the truth {np.sum(z < 0)}/{z.size}"
        )
    told = [row for row in rows if "with_effects" in row]
    print(f"  the model with the effect (what the summary shows): {len(told)} seeds")
    for label, subset in (("seeds 0-9", [r for r in told if r["seed"] <= 9]), ("all", told)):
        parts = []
        for name in ("N", "B", "K", "c1"):
            count, total = _covered(
                subset, "with_effects", name, lambda row, name=name: row["truth"][name]
            )
            parts.append(f"{name} {_share(count, total)}")
        print(f"    90 % intervals holding the truth, {label}: " + ", ".join(parts))
    if told:
        ratio = [row["noise"]["K"][0] / row["truth"]["K"] for row in told if "K" in row["noise"]]
        if ratio:
            print(
                f"  the noise model without it read K at {np.median(ratio):.0f}x the truth "
                f"(median of {len(ratio)}; range {min(ratio):.0f}-{max(ratio):.0f}x)"
            )
    failed = [row["seed"] for row in told if not row.get("with_effects_passed", True)]
    print(f"  model with the effect failed its checks on seeds: {failed or 'none'}")


def least_squares(seeds: list[int], minutes: float) -> None:
    """The least-squares slope of each gyro on the recorded temperature, per seed and over
    seeds (mean, its standard error, sd)."""
    from bayescal.capabilities._demo import REFERENCE_TEMPERATURE, THERMAL_SLOPE, demo_recording

    slopes = []
    for seed in seeds:
        columns, _ = demo_recording(seed, minutes)
        temperature = columns["temperature[degC]"] - REFERENCE_TEMPERATURE
        design = np.column_stack([np.ones_like(temperature), temperature])
        row = [
            np.linalg.lstsq(design, columns[f"gyro_{axis}[deg/s]"], rcond=None)[0][1]
            for axis in "zxy"
        ]
        slopes.append(row)
        print(f"seed {seed}: gyro_z {row[0]:.5f}, gyro_x {row[1]:+.5f}, gyro_y {row[2]:+.5f}")
    slopes = np.array(slopes)
    print(f"least-squares slope on the temperature, deg/s/degC, seeds {seeds[0]}-{seeds[-1]}:")
    for column, (name, truth) in enumerate(
        (("gyro_z", THERMAL_SLOPE), ("gyro_x", 0.0), ("gyro_y", 0.0))
    ):
        values = slopes[:, column]
        error = values.std(ddof=1) / math.sqrt(values.size)
        print(
            f"  {name} (truth {truth:g}): mean {values.mean():.5f} (se {error:.5f}), "
            f"sd {values.std(ddof=1):.5f}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", default="0-49")
    parser.add_argument("--minutes", type=float, default=25.0)
    parser.add_argument("--out", default="demo_story.jsonl")
    parser.add_argument("--least-squares", action="store_true")
    args = parser.parse_args()
    if args.least_squares:
        least_squares(_seeds(args.seeds), args.minutes)
        return
    out = Path(args.out)
    rows = [json.loads(line) for line in out.read_text().splitlines()] if out.exists() else []
    done = {row["seed"] for row in rows}
    for seed in _seeds(args.seeds):
        if seed in done:
            continue
        row = run_seed(seed, args.minutes)
        with out.open("a") as handle:
            handle.write(json.dumps(row) + "\n")
        rows.append(row)
        print(
            f"seed {seed}: {row['effects']} in {row['seconds']:.0f} s; "
            f"discovery c1 {row.get('discovery_c1')}; K {row.get('with_effects', {}).get('K')}",
            flush=True,
        )
    summarise([row for row in rows if row["seed"] in set(_seeds(args.seeds))])


if __name__ == "__main__":
    main()
