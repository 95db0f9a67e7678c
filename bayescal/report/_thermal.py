"""A thermal calibration rendered as the text ``bayescal thermal`` prints."""

import math

import numpy as np


def thermal_text(document: dict) -> str:
    """The lines ``bayescal thermal fit`` and ``update`` print, from the calibration file's
    content."""
    lines = [
        f"bayescal thermal: channel {document['channel']} [{document['unit']}], degree "
        f"{document['degree']}, T0 = {document['reference_temperature']:g} "
        f"{document['temperature_unit']}, range {document['temperature_range'][0]:.4g}-"
        f"{document['temperature_range'][1]:.4g}"
    ]
    sd = np.sqrt(np.diag(np.asarray(document["covariance"])))
    bayes = document["bayesian"]
    for j, (value, spread, unit) in enumerate(
        zip(document["coefficients"], sd, document["coefficient_units"], strict=True)
    ):
        row = (
            f"  c{j} {value:.6g} +- {spread:.3g} {unit}  [90%: {bayes['coefficient_q05'][j]:.6g},"
            f" {bayes['coefficient_q95'][j]:.6g}]"
        )
        if "classical" in document:
            classical = document["classical"]
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
    if "drift" in document:
        drift = document["drift"]
        lines.append(
            f"  drift since the prior calibration: {drift['scale']:.3g} {drift['unit']}"
            + (
                f" (learned, 90%: {drift['q05']:.3g}-{drift['q95']:.3g})"
                if drift["learned"]
                else " (given)"
            )
        )
    if "offsets" in document:
        lines.append(
            "  period offsets: "
            + ", ".join(
                f"{m:.4g} +- {s:.2g}"
                for m, s in zip(document["offsets"]["mean"], document["offsets"]["sd"], strict=True)
            )
        )
    lines.append(
        "  noise: "
        + ", ".join(
            f"{k} {v['mean']:.3g} {v['unit']}" for k, v in document["noise"].items() if k != "terms"
        )
    )
    diagnostics = bayes["diagnostics"]
    lines.append(
        "  posterior checks "
        + ("passed" if diagnostics["passed"] else "FAILED: " + "; ".join(diagnostics["failures"]))
    )
    return "\n".join(lines)
