"""How long to record, checked: the width the planner predicts at the length it recommends,
against the width realised on records of that length.

    python benchmarks/plan_validation.py [--records 50] [--seed 1]

A pilot record (27 minutes at 10 Hz: white noise N = 0.005 deg/s/sqrt(Hz), bias instability
B = 0.002 deg/s, rate random walk K = 0.0003 deg/s*sqrt(Hz)) is fitted with those terms and
``bc.plan_recording`` asked for N to +-0.5 %, B to +-10 % and K to +-20 % (90 % intervals).
For each parameter, ``--records`` records of the length it recommends are simulated from the
truth and fitted the same way; printed: the target (the predicted width at that length), the
median realised relative half-width (q95 - q05) / 2 over the posterior median, their ratio,
and the spread of the realised widths. Target (issue 37): the ratio within 0.8-1.2 for N, K
and B.
"""

import argparse
import time

import numpy as np

import bayescal as bc

RATE = 10.0
TRUTH = {"N": 0.005, "B": 2e-3, "K": 3e-4}
TERMS = ("white", "bias_instability", "rate_random_walk")
TARGET = {"N": 0.005, "B": 0.1, "K": 0.2}


def realised_width(fit, name: str) -> float:
    summary = fit.parameters[name]
    median = float(np.median(np.ravel(fit.draws[name])))
    return (summary.q95 - summary.q05) / 2 / median


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--records", type=int, default=50)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    model = bc.NoiseModel(RATE, 0.4, **TRUTH)
    started = time.perf_counter()
    pilot = bc.fit_noise(model.simulate(2**14, seed=args.seed), RATE, terms=TERMS, seed=0)
    plan = bc.plan_recording(pilot, TARGET, seed=args.seed)
    print(
        f"plan validation: pilot {pilot.classical.duration_s / 60:.1f} min at {RATE:g} Hz "
        f"({', '.join(f'{k}={v:g}' for k, v in TRUTH.items())}); {args.records} records per "
        "recommended length; relative half-widths of 90 % intervals"
    )
    print(f"  {'':3}{'length':>10}{'target':>9}{'realised':>10}{'ratio':>7}   realised 5-95 %")
    for name, wanted in TARGET.items():
        term = plan.terms[name]
        if term.length_s is None:
            print(f"  {name:<3} no length: {term.reason}")
            continue
        n = round(term.length_s * RATE)
        widths = []
        for record in range(args.records):
            values = model.simulate(n, seed=10_000 * (args.seed + 1) + record)
            fit = bc.fit_noise(values, RATE, terms=TERMS, seed=record)
            widths.append(realised_width(fit, name))
        realised = float(np.median(widths))
        low, high = np.quantile(widths, [0.05, 0.95])
        print(
            f"  {name:<3}{term.length_s / 3600:>8.2f} h{100 * wanted:>8.3g}%"
            f"{100 * realised:>9.3g}%{realised / wanted:>7.2f}   {100 * low:.3g}-{100 * high:.3g} %"
        )
    print(f"  {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
