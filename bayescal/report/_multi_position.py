"""A multi-position calibration rendered: the JSON document of ``bayescal multi-position``
(:func:`multi_position_result`) and the table it prints (:func:`multi_position_text`), both
read from the :class:`~bayescal.MultiPositionCalibration`."""

from importlib.metadata import version

from scipy import stats

from ..capabilities._multi_position import MultiPositionCalibration, scale_unit
from ..classical._multi_position import ClassicalCalibration, calibration_matrices
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
            "unit": _residual_unit(calibration),
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
        parameters = calibration.summary
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


def _residual_unit(calibration: MultiPositionCalibration) -> str:
    """The classical residual's unit: the readings' (six-face: raw components) or m/s^2
    (free orientations: magnitudes)."""
    return calibration.unit if calibration.classical.six_face else "m/s^2"


def multi_position_text(
    calibration: MultiPositionCalibration, *, channels, notes: list[str]
) -> str:
    """The table ``bayescal multi-position`` prints."""
    classical, poses = calibration.classical, calibration.poses
    percent = f"{100 * classical.confidence:g}%"
    gravity = classical.gravity
    bayesian = calibration.bayesian
    lines = [
        f"bayescal multi-position: {','.join(channels)} [{calibration.unit}], "
        f"{classical.orientations} orientations",
        f"  poses: {poses.n} ({classical.distinct_orientations} distinct orientations); "
        f"{calibration.found_by}",
        f"  g_local {gravity.value:.7g} +- {gravity.uncertainty:.2g} m/s^2 "
        f"(1 sd; {gravity.source})",
        f"  classical residual RMS {classical.residual_rms:.3g} {_residual_unit(calibration)} "
        f"({classical.dof} degrees of freedom)",
        "",
        f"  {'':17}{'classical (' + percent + ' half-width)':<32}"
        f"{'Bayesian mean [90%]' if bayesian is not None else '':<44}unit",
    ]
    posterior = {} if bayesian is None else calibration.summary
    units = calibration.units
    for name, (value, uncertainty) in classical.parameters.items():
        row = f"{value:.7g} +- {uncertainty:.2g}"
        shown = ""
        if name in posterior:
            p = posterior[name]
            shown = f"{p['mean']:.7g} [{p['q05']:.6g}, {p['q95']:.6g}]"
        lines.append(f"  {name:<17}{row:<32}{shown:<44}{units[name]}")
    for name in ("pose_scatter", "g_local"):
        if name in posterior:
            p = posterior[name]
            shown = f"{p['mean']:.4g} [{p['q05']:.4g}, {p['q95']:.4g}]"
            lines.append(f"  {name:<17}{'':<32}{shown:<44}{p['unit']}")
    if bayesian is not None:
        diagnostics = bayesian.diagnostics
        lines.append(
            "  posterior checks "
            + ("passed" if diagnostics.passed else "FAILED: " + "; ".join(diagnostics.failures))
        )
        lines += [f"  - {note}" for note in _comparison(classical, posterior)]
    lines += [f"  note: {note}" for note in notes]
    return "\n".join(lines)
