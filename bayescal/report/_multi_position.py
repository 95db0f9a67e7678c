"""A multi-position calibration rendered: the JSON document of ``bayescal multi-position``
and the table it prints."""

from importlib.metadata import version

from scipy import stats

from ..capabilities._multi_position import MultiPositionCalibration, scale_unit
from ..classical._multi_position import ClassicalCalibration, calibration_matrices
from ..inference._mcmc import summarize
from ..recording._units import parse_unit

MODEL = {
    "free": "a = T K (r - b), T = [[1, -a_yz, a_zy], [0, 1, -a_zx], [0, 0, 1]], K = diag(scale); "
    "free orientations: ||T K (m_i - b)|| = g_local for each pose mean m_i (Tedaldi, Pretto & "
    "Menegatti, ICRA 2014)",
    "six-face": "m_i = M f_i + b with f_i = +-g_local e_axis of the pose's face, "
    "M^-1 = R T K (Ferraris et al. 1995); a = T K (r - b) in the sensor's body frame and "
    "R T K (r - b) in the fixture's, R the rotation by the rotation vector (rotation_x, y, z)",
}


def multi_position_result(
    calibration: MultiPositionCalibration, *, source: str, channels, notes: list[str]
) -> dict:
    """The JSON document of ``bayescal multi-position``.

    Over 80 lines: the document's layout, block after block, as the JSON holds it.
    """
    unit, rate_hz, poses = calibration.unit, calibration.rate_hz, calibration.poses
    classical, bayesian = calibration.classical, calibration.bayesian
    gravity, found_by = classical.gravity, calibration.found_by
    units = calibration.units
    pose_list = []
    for i in range(poses.n):
        entry = {
            "start_s": float(poses.start_s[i]),
            "stop_s": float(poses.stop_s[i]),
            "n_samples": int(poses.count[i]),
            "mean": poses.mean[i],
            "sd": poses.sd[i],
        }
        if classical.face_labels is not None:
            entry["face"] = classical.face_labels[i]
        pose_list.append(entry)
    matrices = calibration_matrices(classical.values, classical.six_face)
    block = {
        "parameters": {
            name: {"value": value, "uncertainty": uncertainty, "unit": units[name]}
            for name, (value, uncertainty) in classical.parameters.items()
        },
        "confidence": classical.confidence,
        "degrees_of_freedom": classical.dof,
        "residual_rms": {
            "value": classical.residual_rms,
            "unit": unit if classical.six_face else "m/s^2",
            "of": "raw components m_i - M f_i - b"
            if classical.six_face
            else "magnitudes ||T K (m_i - b)|| - g",
        },
        "conditioning": classical.conditioning,
        "matrices": {
            **matrices,
            "units": {
                "misalignment_T": "1",
                "scale_K": scale_unit(unit),
                "calibration_TK": scale_unit(unit),
                "sensitivity": f"{unit} per m/s^2 (rows: sensing axes in the body frame)",
                "offset_b": unit,
                **(
                    {
                        "rotation_R": "1",
                        "sensitivity_fixture": f"{unit} per m/s^2 (Ferraris' M; rows: sensing "
                        "axes in the fixture frame)",
                    }
                    if classical.six_face
                    else {}
                ),
            },
        },
        "method": "least squares with g fixed at g_local (Levenberg-Marquardt), covariance "
        "s^2 (J^T J)^-1 with s^2 the residual variance over the degrees of freedom, Student-t "
        "half-widths; the scales include gravity's uncertainty",
    }
    parsed = parse_unit(unit)
    if parsed.quantity == "acceleration":
        # Scales (m/s^2 per m/s^2) and offsets (m/s^2) again in SI, as two-position gives them.
        block["si"] = {}
        for name, (value, uncertainty) in classical.parameters.items():
            if name.startswith("scale_"):
                factor, si_unit = 1 / parsed.to_si, "1"
            elif name.startswith("offset_"):
                factor, si_unit = parsed.to_si, "m/s^2"
            else:
                continue
            block["si"][name] = {
                "value": value * factor,
                "uncertainty": uncertainty * factor,
                "unit": si_unit,
            }
    result = {
        "bayescal_version": version("bayescal"),
        "command": "multi-position",
        "source": source,
        "channels": list(channels),
        "unit": unit,
        "rate_hz": rate_hz,
        "orientations": classical.orientations,
        "model": MODEL[classical.orientations],
        "poses": {
            "count": poses.n,
            "distinct_orientations": classical.distinct_orientations,
            "found_by": found_by,
            "unit": unit,
            "list": pose_list,
        },
        "gravity": {
            "value": gravity.value,
            "uncertainty": gravity.uncertainty,
            "unit": "m/s^2",
            "uncertainty_is": "one standard deviation",
            "source": gravity.source,
        },
        "notes": notes,
        "classical": block,
    }
    if bayesian is not None:
        parameters = {
            name: summarize(
                bayesian.draws[name], units[name], bayesian.map_values[name], bayesian.map_sd[name]
            )
            for name in bayesian.names
        }
        result["bayesian"] = {
            "parameters": parameters,
            "model": "each pose mean Gaussian: white-noise covariance of a mean (per-axis "
            "variance / count) plus an isotropic pose scatter sigma_p in the calibrated frame; "
            + (
                "full 3-vector likelihood per pose"
                if classical.six_face
                else "orientations uniform on the sphere and integrated out (magnitude "
                "residual, Jacobian |det T K| included)"
            )
            + "; g_local from its prior (the data cannot tell it from the scales)",
            "priors": "scales log-normal at the classical value, sd 1 in the log; "
            "misalignment angles N(0, 0.1 rad); mounting rotation N(0, 0.3 rad); offsets "
            "normal at the classical value, sd 1 g; pose_scatter log-normal at the classical "
            "residual RMS, sd 3 in the log",
            "diagnostics": bayesian.diagnostics.as_dict(),
            "comparison": _comparison(classical, parameters),
        }
    return result


def _comparison(classical: ClassicalCalibration, parameters: dict) -> list[str]:
    """Where the two answers disagree beyond their uncertainties, and why."""
    notes = []
    t = float(stats.t.ppf(0.5 + classical.confidence / 2, classical.dof))
    for name, (value, half_width) in classical.parameters.items():
        posterior = parameters[name]
        standard_error = half_width / t
        if abs(posterior["mean"] - value) > half_width:
            notes.append(
                f"{name}: the posterior mean {posterior['mean']:.6g} lies outside the classical "
                f"interval {value:.6g} +- {half_width:.3g}: the posterior weights each pose by "
                "its own noise, the classical fit weights all poses equally"
            )
        elif posterior["sd"] > 1.5 * standard_error:
            notes.append(
                f"{name}: the posterior sd is {posterior['sd'] / standard_error:.3g}x the "
                "classical standard error: the pose scatter is poorly known from "
                f"{classical.dof} degrees of freedom"
            )
    return notes


def multi_position_text(result: dict) -> str:
    classical = result["classical"]
    percent = f"{100 * classical['confidence']:g}%"
    poses = result["poses"]
    gravity = result["gravity"]
    residual = classical["residual_rms"]
    lines = [
        f"bayescal multi-position: {','.join(result['channels'])} [{result['unit']}], "
        f"{result['orientations']} orientations",
        f"  poses: {poses['count']} ({poses['distinct_orientations']} distinct orientations); "
        f"{poses['found_by']}",
        f"  g_local {gravity['value']:.7g} +- {gravity['uncertainty']:.2g} m/s^2 "
        f"(1 sd; {gravity['source']})",
        f"  classical residual RMS {residual['value']:.3g} {residual['unit']} "
        f"({classical['degrees_of_freedom']} degrees of freedom)",
        "",
        f"  {'':17}{'classical (' + percent + ' half-width)':<32}"
        f"{'Bayesian mean [90%]' if 'bayesian' in result else '':<44}unit",
    ]
    bayesian = result.get("bayesian", {}).get("parameters", {})
    for name, entry in classical["parameters"].items():
        row = f"{entry['value']:.7g} +- {entry['uncertainty']:.2g}"
        posterior = ""
        if name in bayesian:
            p = bayesian[name]
            posterior = f"{p['mean']:.7g} [{p['q05']:.6g}, {p['q95']:.6g}]"
        lines.append(f"  {name:<17}{row:<32}{posterior:<44}{entry['unit']}")
    for name in ("pose_scatter", "g_local"):
        if name in bayesian:
            p = bayesian[name]
            posterior = f"{p['mean']:.4g} [{p['q05']:.4g}, {p['q95']:.4g}]"
            lines.append(f"  {name:<17}{'':<32}{posterior:<44}{p['unit']}")
    if "bayesian" in result:
        diagnostics = result["bayesian"]["diagnostics"]
        lines.append(
            "  posterior checks "
            + (
                "passed"
                if diagnostics["passed"]
                else "FAILED: " + "; ".join(diagnostics["failures"])
            )
        )
        lines += [f"  - {note}" for note in result["bayesian"]["comparison"]]
    lines += [f"  note: {note}" for note in result["notes"]]
    return "\n".join(lines)
