"""The README's figure (docs/figures/allan_posterior.png): what bayescal finds on a simulated
gyro with known noise (white noise, bias instability, rate random walk) — the measured Allan
deviation with its chi-square intervals, and the posterior band of the model's Allan deviation,
beside the truth. Prints each parameter's 90 % interval beside its true value.

    python docs/figures/allan_posterior.py        # rewrites the PNG (seeded: the same figure)
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import bayescal as bc

RATE_HZ = 100.0
N_SAMPLES = 2**17  # 22 minutes
TRUTH = {"bias": 0.4, "N": 0.0035, "B": 4e-4, "K": 3e-4}  # deg/s, deg/s/√Hz, deg/s, deg/s·√Hz
DRAWS = 200


def main() -> None:
    truth = bc.NoiseModel(rate_hz=RATE_HZ, **TRUTH)
    y = truth.simulate(N_SAMPLES, seed=3)
    fit = bc.fit_noise(
        y, RATE_HZ, terms="white,bias_instability,rate_random_walk", unit="deg/s", seed=0
    ).check()
    allan = fit.classical.allan
    tau = np.geomspace(allan.tau[0], allan.tau[-1], 60)

    draws = {name: np.ravel(values) for name, values in fit.draws.items() if name in "NBK"}
    picked = np.random.default_rng(0).choice(next(iter(draws.values())).size, DRAWS)
    curves = np.array(
        [
            np.sqrt(
                bc.NoiseModel(
                    rate_hz=RATE_HZ, **{p: v[i] for p, v in draws.items()}
                ).allan_variance(tau)
            )
            for i in picked
        ]
    )
    low, high = np.quantile(curves, [0.05, 0.95], axis=0)

    figure, axes = plt.subplots(figsize=(6.4, 4.0), dpi=110)
    axes.fill_between(
        tau,
        low,
        high,
        color="tab:blue",
        alpha=0.35,
        lw=0,
        label="posterior 90 % band of the model's ADEV",
    )
    axes.errorbar(
        allan.tau,
        allan.deviation,
        yerr=[allan.deviation - allan.ci_low, allan.ci_high - allan.deviation],
        fmt="o",
        ms=3,
        color="k",
        lw=1,
        label="measured ADEV, 95 % chi-square",
    )
    axes.plot(tau, np.sqrt(truth.allan_variance(tau)), "--", color="tab:red", lw=1.2, label="truth")
    axes.set(
        xscale="log",
        yscale="log",
        xlabel="averaging time τ [s]",
        ylabel="Allan deviation [deg/s]",
        title="A simulated gyro, 22 min at 100 Hz",
    )
    axes.legend(fontsize=8, loc="lower left")
    axes.grid(True, which="both", alpha=0.2)
    figure.tight_layout()
    figure.savefig(Path(__file__).with_suffix(".png"), metadata={"Software": None})
    summary = {name: (fit.summary[name]["q05"], fit.summary[name]["q95"]) for name in "NBK"}
    print(
        {name: (f"{low:.3g}", f"{high:.3g}", TRUTH[name]) for name, (low, high) in summary.items()}
    )


if __name__ == "__main__":
    main()
