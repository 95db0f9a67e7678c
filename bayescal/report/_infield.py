"""An in-field update rendered as the text ``bayescal thermal infield`` prints."""


def _interval(entry: dict, digits: int = 3) -> str:
    return (
        f"{entry['mean']:.{digits}g} +- {entry['sd']:.2g} {entry['unit']} "
        f"[90%: {entry['q05']:.{digits}g}, {entry['q95']:.{digits}g}]"
    )


def infield_text(document: dict) -> str:
    """The lines ``bayescal thermal infield`` prints, from its JSON document."""
    alignment = document["alignment"]
    attitude = alignment["coarse_attitude_deg"]
    lines = [
        f"bayescal thermal infield: alignment {alignment['start_s']:g}-{alignment['stop_s']:g} s "
        f"at latitude {alignment['latitude_deg']:g} deg; coarse roll {attitude['roll']:.3f}, "
        f"pitch {attitude['pitch']:.3f}, heading {attitude['heading']:.3f} deg",
        "  heading error (computed - true) at the end: "
        + _interval(document["heading_error"])
        + (
            "  (at rest: the east bias level seen as heading)"
            if not (document.get("taxi") or {}).get("informative")
            else "  (told by the taxi)"
        )
        + "; correlation with the east level "
        + f"{document['heading_error']['correlation_with_east_level']:+.2f}",
        "  projected gyro bias           posterior                                  prior sd",
    ]
    taxi = document.get("taxi")
    if taxi:
        lines.insert(
            1,
            f"  taxi {taxi['start_s']:g}-{taxi['stop_s']:g} s, track headings "
            f"{', '.join(f'{h:g}' for h in taxi['track_heading_deg']) or 'none'} deg: "
            f"{sum(taxi['steps_on_legs'])} s on the legs ({taxi['why']})",
        )
    for direction, kinds in document["projections"].items():
        for kind, entry in kinds.items():
            told = "informed" if entry["informed"] else "NOT informed by the alignment"
            lines.append(
                f"    {direction:5} {kind:5}  {_interval(entry)}  {entry['prior_sd']:.2g}  {told}"
            )
    for name, axis in document["axes"].items():
        lines.append(f"  {name}: updated ({axis['why']})")
        classical = document["classical"]["axes"][name]
        for j, (value, sd, unit) in enumerate(
            zip(axis["coefficients"], axis["sd"], axis["coefficient_units"], strict=True)
        ):
            patent = (
                f"   (the patent's pipeline: {classical['coefficients'][j]:.6g} +- "
                f"{classical['covariance'][j][j] ** 0.5:.3g})"
                if "coefficients" in classical
                else "   (the patent's pipeline leaves the vertical gyro out)"
            )
            lines.append(f"    c{j} {value:.6g} +- {sd:.3g} {unit}{patent}")
    heading = document["classical"]["heading_error_deg"]
    lines.append(
        "  the patent's pipeline: tilt-rate points, "
        + (
            f"less the heading error's Earth-rate equivalent ({heading:.4g} deg at the park's end)"
            if heading is not None
            else "with no heading error taken off (no taxi told it)"
        )
        + ", interpolated with the old calibration by their weights, no aging allowed"
    )
    drift = document["drift"]
    if drift["learned"]:
        lines.append(
            f"  aging since the calibration (learned): {drift['scale']:.3g} {drift['unit']} "
            f"[90%: {drift['q05']:.3g}, {drift['q95']:.3g}]"
        )
    else:
        lines.append(f"  aging since the calibration (given): {drift['scale']:.3g} {drift['unit']}")
    lines.extend(f"  note: {note}" for note in document["notes"])
    checks = document["checks"]
    lines.append(
        "  checks " + ("passed" if checks["passed"] else "FAILED: " + "; ".join(checks["failures"]))
    )
    return "\n".join(lines)
