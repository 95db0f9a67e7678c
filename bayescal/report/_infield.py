"""An in-field update rendered as the text ``bayescal thermal infield`` prints
(:func:`infield_text`, from its JSON document) and as its page (:func:`infield_page`, ``--report
PAGE.html``, from the :class:`~bayescal.InFieldUpdate` itself): the park and the taxi's computed
track, the patent's points before and after the heading correction, the old and updated
calibrations with their 90 % bands, and the 1 h free-inertial position error each leaves as the
posterior predicts it. The figures are :mod:`._figures`'."""

import datetime
import math
from importlib.metadata import version

import numpy as np

from ..capabilities._infield import InFieldUpdate
from ..capabilities._infield_summary import DEG_PER_HOUR
from ..models.effects.earth_rotation import EARTH_RATE
from ..recording._units import parse_unit
from ._figures import (
    embedded,
    infield_calibration_figure,
    infield_drift_figure,
    infield_points_figure,
    infield_track_figure,
)
from ._format import esc, interval, num, page_start, pretty_unit, quantity

FLIGHTS = {"parked": 0.0, "at 250 m/s, turning 90° every 15 min": 250.0}
"""The free-inertial checks of the page: flight -> ground speed, m/s (the benchmark's)."""
SHOWN_UNIT = "deg/h"
"""The unit of the page's gyro biases."""


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
            f"{sum(taxi['steps_on_legs'])} s on the legs"
            + (
                f", {taxi['positions']['fixes_in_taxi']} position fixes"
                if taxi.get("positions")
                else ""
            )
            + f" ({taxi['why']})",
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


# ---------------------------------------------------------------------------------------------
# The page


def _summary_cell(entry: dict) -> str:
    """A posterior summary (mean, sd, 90 % interval) with its unit, HTML."""
    return (
        f"{interval(entry['mean'], entry['q05'], entry['q95'], entry['unit'])} "
        f"<span class='note'>(sd {quantity(entry['sd'], entry['unit'], 2)})</span>"
    )


def _heading_html(update: InFieldUpdate) -> list[str]:
    """The heading error, what told it, and what the patent's pipeline took off."""
    heading, taxi = update.heading_error, update.taxi
    told = bool(taxi and taxi["informative"])
    parts = [
        "<h2>Heading error</h2>",
        f"<p><b>Heading error</b> ({esc(heading['definition'])}): "
        f"{_summary_cell(heading)}, correlation with the east bias level "
        f"{heading['correlation_with_east_level']:+.2f}. "
        + (
            "Told by the taxi: the cross-track velocity on the known legs."
            if told
            else "<span class='bad'>Not told</span>: at rest the east bias level is seen as "
            "heading; the east level stays at its prior."
        )
        + "</p>",
    ]
    if taxi is not None:
        step = update.alignment["filter_step_s"]
        legs = ", ".join(
            f"{heading:g}°: {quantity(count * step, 's', 4)}"
            for heading, count in zip(taxi["track_heading_deg"], taxi["steps_on_legs"], strict=True)
        )
        parts.append(
            f"<p>Taxi {quantity(taxi['start_s'], 's')} to {quantity(taxi['stop_s'], 's')}; "
            f"time on the known legs: {legs or 'none (no track heading given)'}: "
            f"{esc(taxi['why'])}.</p>"
        )
    taken = update.classical["heading_error_deg"]
    if taken is not None:
        latitude = math.radians(update.alignment["latitude_deg"])
        equivalent = EARTH_RATE * math.cos(latitude) * math.radians(taken) / DEG_PER_HOUR
        parts.append(
            "<p>The patent's pipeline (steps m–n) took the smoother's heading error at the "
            f"park's end, {quantity(taken, 'deg')}, as exact: its Earth-rate equivalent "
            f"Ω cos L ψ = {quantity(equivalent, SHOWN_UNIT)} came off every east tilt-rate "
            "point.</p>"
        )
    else:
        parts.append(
            "<p>The patent's pipeline took no heading error off its points (no taxi told it).</p>"
        )
    return parts


def _projections_table(update: InFieldUpdate) -> str:
    rows = []
    for direction, kinds in update.projections.items():
        for kind, entry in kinds.items():
            told = "yes" if entry["informed"] else "<span class='bad'>no</span>"
            rows.append(
                f"<tr><td>{esc(direction)}</td><td>{esc(kind.replace('_', ' '))}</td>"
                f"<td class='num'>{_summary_cell(entry)}</td>"
                f"<td class='num'>{quantity(entry['prior_sd'], entry['unit'], 2)}</td>"
                f"<td>{told}</td></tr>"
            )
    return (
        "<table><thead><tr><th>projection</th><th>of</th><th>posterior mean [5 %, 95 %]</th>"
        "<th>prior sd</th><th>informed</th></tr></thead><tbody>"
        + "".join(rows)
        + "</tbody></table>"
    )


def _coefficients_table(update: InFieldUpdate) -> str:
    rows = []
    for name, new in update.calibration.items():
        old = update.old_calibration[name]
        classical = update.classical["axes"][name]
        sd, old_sd = np.sqrt(np.diag(new.covariance)), np.sqrt(np.diag(old.covariance))
        for j, unit in enumerate(new.coefficient_units):
            patent = (
                f"{quantity(classical['coefficients'][j], unit, 6)} ± "
                f"{num(math.sqrt(classical['covariance'][j][j]), 3)}"
                if "coefficients" in classical
                else "<span class='note'>left out (vertical gyro)</span>"
            )
            rows.append(
                f"<tr><td>{esc(name)}</td><td>c{j}</td>"
                f"<td class='num'>{quantity(old.coefficients[j], unit, 6)} ± {num(old_sd[j], 3)}"
                f"</td><td class='num'>{quantity(new.coefficients[j], unit, 6)} ± "
                f"{num(sd[j], 3)}</td><td class='num'>{patent}</td></tr>"
            )
    return (
        "<table><thead><tr><th>gyro</th><th>coefficient</th><th>old ± sd</th>"
        "<th>updated ± sd</th><th>the patent's pipeline ± sd</th></tr></thead><tbody>"
        + "".join(rows)
        + "</tbody></table>"
    )


def _drift_html(update: InFieldUpdate) -> list[str]:
    """The 1 h free-inertial check as the posterior predicts it, old against updated."""
    temperature = [float(np.mean(p["temperature"])) for p in update.points.values()]
    errors = {
        flight: {
            label: update.position_error(temperature, speed=speed, calibration=calibration)
            for label, calibration in (("old", update.old_calibration), ("updated", None))
        }
        for flight, speed in FLIGHTS.items()
    }
    temperature_unit = next(iter(update.calibration.values())).temperature_unit
    rows = []
    for flight, by_calibration in errors.items():
        cells = []
        for label in ("old", "updated"):
            error = by_calibration[label]
            mean = np.asarray(error["mean"])
            rms = math.sqrt(float(mean @ mean) + error["sd"] ** 2)
            cells.append(
                f"<td class='num'>{quantity(np.hypot(*mean), 'm', 3)}</td>"
                f"<td class='num'>{quantity(rms, 'm', 3)}</td>"
            )
        rows.append(
            f"<tr><td>{esc(flight)}</td>{''.join(cells)}<td class='num'>"
            f"{quantity(by_calibration['updated']['sd'], 'm', 3)}</td></tr>"
        )
    hours = next(iter(errors.values()))["updated"]["duration_s"] / 3600
    return [
        f"<h2>What it buys in flight: {hours:g} h of free inertial navigation</h2>",
        "<p>The next mission aligns where this one parked, then navigates free-inertially with "
        "the gyros compensated at their temperature (steps p–q), each gyro at its mean over the "
        "park's points ("
        + ", ".join(
            f"{esc(name)} {quantity(t, temperature_unit)}"
            for name, t in zip(update.points, temperature, strict=True)
        )
        + "). The horizontal error is linear in the gyros' residual biases, so each joint "
        "posterior draw of the three polynomials gives one draw of it: with the old "
        "calibration its mean is how far the posterior says the old one is off; the sd "
        "(root of the covariance's trace) is the posterior's own uncertainty, the same for "
        "both. The realised error needs the truth (a simulation, or a flight beside a position "
        "reference): <code>benchmarks/infield_taxi.py</code> measures it; this page shows the "
        "prediction only.</p>",
        "<table><thead><tr><th>flight</th><th>old: |mean error|</th><th>old: rms</th>"
        "<th>updated: |mean error|</th><th>updated: rms</th><th>predicted sd</th></tr></thead>"
        "<tbody>" + "".join(rows) + "</tbody></table>",
        embedded(infield_drift_figure(errors), "predicted position error, old and updated"),
    ]


def _checks_html(update: InFieldUpdate) -> list[str]:
    checks = update.checks
    sampler = checks["sampler"]
    innovations = checks["innovations"]
    status = (
        "<span class='ok'>passed</span>" if update.passed else "<span class='bad'>FAILED</span>"
    )
    if "rhat" in sampler:
        sampled = (
            f"the aging scale's posterior: {sampler['n_steps']} steps × {sampler['n_walkers']} "
            f"walkers, max R-hat {num(max(sampler['rhat'].values()))}, min bulk ESS "
            f"{num(min(sampler['ess_bulk'].values()))}, acceptance "
            f"{num(sampler['acceptance_fraction'], 3)}"
        )
    else:
        sampled = esc(sampler["method"])
    parts = [
        "<h2>Checks</h2>",
        f"<p>All checks: {status}. Sampler: {sampled}. Velocity innovations: sum of NIS "
        f"{num(innovations['sum_nis'])} over {innovations['dof']} (99.9 % χ² limit "
        f"{num(innovations['upper_limit'])}).</p>",
    ]
    legs = checks["taxi_innovations"]
    if legs:
        parts.append(
            "<p>Cross-track innovations per leg: "
            + "; ".join(
                f"{leg['track_heading_deg']:g}°: sum of NIS {num(leg['sum_nis'])} over "
                f"{leg['dof']} steps (limit {num(leg['upper_limit'])}) "
                + (
                    "<span class='ok'>passed</span>"
                    if leg["passed"]
                    else "<span class='bad'>FAILED</span>"
                )
                for leg in legs
            )
            + "</p>"
        )
    if update.notes:
        parts.append(
            "<ul class='note'>"
            + "".join(f"<li>{esc(note)}</li>" for note in update.notes)
            + "</ul>"
        )
    return parts


def infield_page(update: InFieldUpdate, *, source: str) -> str:
    """The self-contained HTML page of an in-field update (``bayescal thermal infield
    --report``): the heading error, the park and taxi track, the points before and after the
    heading correction, the old and updated calibrations with their 90 % bands, and the
    position error after 1 h of free inertial navigation with either, as the posterior
    predicts it. Gyro biases are shown in deg/h; the tables keep the calibrations' units.

    Over 80 lines: the page's sections in order."""
    created = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    title = f"In-field update: {source}"
    alignment = update.alignment
    scales = {
        name: parse_unit(calibration.unit).to_si / DEG_PER_HOUR
        for name, calibration in update.calibration.items()
    }
    temperature_unit = next(iter(update.calibration.values())).temperature_unit
    parts = [
        *page_start(title),
        f"<p class='note'>Alignment {quantity(alignment['start_s'], 's')} to "
        f"{quantity(alignment['stop_s'], 's')} at latitude "
        f"{quantity(alignment['latitude_deg'], 'deg')}, height "
        f"{quantity(alignment['height_m'], 'm')}; park heading "
        f"{quantity(alignment['park_attitude_deg']['heading'], 'deg')} — bayescal "
        f"{esc(version('bayescal'))}, {created}</p>",
    ]
    if not update.passed:
        parts.append(
            "<div class='alarm'><h2>HEALTH CHECK FAILED</h2><p>Do not use these numbers:</p><ul>"
            + "".join(f"<li>{esc(failure)}</li>" for failure in update.checks["failures"])
            + "</ul></div>"
        )
    parts += _heading_html(update)
    parts += [
        "<h2>The park and the taxi</h2>",
        "<p>The computed track (free-inertial, from the coarse alignment), north and east of "
        "the start; the steps the filter used on each known leg in colour, the leg's known "
        "heading dashed through them"
        + (
            "; the position fixes the filter measured as crosses, north and east of the first"
            " (the computed track drifts from them by the heading error times the distance run)"
            if update.track.get("fixes") is not None
            else ""
        )
        + ".</p>",
        embedded(infield_track_figure(update.track, update.taxi), "the computed track"),
        "<h2>The points before and after the heading correction</h2>",
        embedded(
            infield_points_figure(
                update.classical,
                scales,
                SHOWN_UNIT,
                update.classical["heading_error_deg"],
                temperature_unit,
            ),
            "the tilt-rate points before and after the heading correction",
        ),
        "<h2>Projected gyro biases</h2>",
        _projections_table(update),
        "<h2>The calibrations: old and updated</h2>",
        embedded(
            infield_calibration_figure(
                update.old_calibration, update.calibration, update.points, scales, SHOWN_UNIT
            ),
            "the old and updated calibrations with their 90 % bands",
        ),
        _coefficients_table(update),
    ]
    drift = update.drift
    parts.append(
        "<p>Aging since the calibration ("
        + ("learned" if drift["learned"] else "given")
        + f"): {quantity(drift['scale'], drift['unit'], 3)}"
        + (
            f" [90 %: {num(drift['q05'], 3)}, {num(drift['q95'], 3)}]&nbsp;"
            f"{esc(pretty_unit(drift['unit']))}"
            if drift["learned"]
            else ""
        )
        + ".</p>"
    )
    parts += _drift_html(update)
    parts += _checks_html(update)
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"
