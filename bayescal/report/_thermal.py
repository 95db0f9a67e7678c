"""A thermal calibration rendered as the text ``bayescal thermal`` prints. Its JSON document
is the calibration file itself (:meth:`~bayescal.ThermalCalibration.save`, the schema of
:mod:`bayescal.capabilities._thermal_file`); the text reads the calibration."""

import math

import numpy as np

from ..capabilities._thermal import ThermalCalibration


def thermal_text(calibration: ThermalCalibration) -> str:
    """The lines ``bayescal thermal fit`` and ``update`` print."""
    low, high = calibration.temperature_range
    lines = [
        f"bayescal thermal: channel {calibration.channel} [{calibration.unit}], degree "
        f"{calibration.degree}, T0 = {calibration.reference:g} "
        f"{calibration.temperature_unit}, range {low:.4g}-{high:.4g}"
    ]
    sd = np.sqrt(np.diag(np.asarray(calibration.covariance)))
    bayes = calibration.bayesian
    classical = calibration.classical
    for j, (value, spread, unit) in enumerate(
        zip(calibration.coefficients, sd, calibration.coefficient_units, strict=True)
    ):
        row = (
            f"  c{j} {value:.6g} +- {spread:.3g} {unit}  [90%: {bayes['coefficient_q05'][j]:.6g},"
            f" {bayes['coefficient_q95'][j]:.6g}]"
        )
        if classical is not None:
            row += (
                f"   classical WLS {classical['coefficients'][j]:.6g} +- "
                f"{math.sqrt(classical['covariance'][j][j]):.3g}"
            )
        lines.append(row)
    if bayes["degree_scores"]:
        lines.append(
            "  degree chosen by one-block-ahead ELPD: "
            + ", ".join(
                f"{d}: {s['elpd']:.1f} (se {s['se_difference']:.1f})"
                for d, s in bayes["degree_scores"].items()
            )
        )
    drift = calibration.drift
    if drift is not None:
        lines.append(
            f"  drift since the prior calibration: {drift['scale']:.3g} {drift['unit']}"
            + (
                f" (learned, 90%: {drift['q05']:.3g}-{drift['q95']:.3g})"
                if drift["learned"]
                else " (given)"
            )
        )
    offsets = calibration.offsets
    if offsets is not None:
        lines.append(
            "  period offsets: "
            + ", ".join(
                f"{m:.4g} +- {s:.2g}" for m, s in zip(offsets["mean"], offsets["sd"], strict=True)
            )
        )
    lines.append(
        "  noise: "
        + ", ".join(
            f"{k} {v['mean']:.3g} {v['unit']}" for k, v in calibration.noise.items() if k != "terms"
        )
    )
    diagnostics = bayes["diagnostics"]
    lines.append(
        "  posterior checks "
        + ("passed" if diagnostics["passed"] else "FAILED: " + "; ".join(diagnostics["failures"]))
    )
    return "\n".join(lines)
