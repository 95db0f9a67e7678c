"""Every figure of the report, one function each, drawn once: the page embeds it
(:func:`embedded`) and ``bayescal discover --out`` writes it as a PNG file (:func:`png`).

Each function takes what it draws (typed: a channel's Allan deviation and posterior bands, a
discovery's curves, a fleet's units) and returns a :class:`matplotlib.figure.Figure` built
directly, never through pyplot: no global matplotlib state is read or changed (a notebook's
backend stays as its user set it), and a figure is freed with its last reference.

Noise figures:

- **Allan deviation**: the measured overlapping ADEV with its classical chi-square bars, and
  two posterior bands (:func:`~bayescal.inference._bands.allan_band`): the model's exact ADEV
  over posterior draws (parameter uncertainty) and the posterior predictive band of the
  measured ADEV (with the estimator's chi-square scatter), both pointwise 90 %.
- **Spectrum**: the binned periodogram the Whittle likelihood fits, as the two-sided amplitude
  spectral density of the samples (white noise reads N), against the model's expected
  periodogram over posterior draws and its predictive band
  (:func:`~bayescal.inference._bands.spectrum_band`).
- **Posterior pairs**: every pair of sampled parameters, the noise scales on log axes.

Discovery figures, each the baseline model beside the final one: the Allan deviation of the
residual with each model's band, the binned spectrum of the increments with each model's,
the residual's block means over time and against the temperature, and the samples'
distribution at a rail.

In-field update figures (``bayescal thermal infield --report``): the computed track of the park
and the taxi with the steps used on each known leg, each gyro's tilt-rate points before and after
the heading correction, the old and updated calibrations with their 90 % bands, and the 1 h
free-inertial position error each calibration leaves as the posterior predicts it.
"""

import base64
import io

import numpy as np

from ..inference._bands import draw_subset
from ..models._terms import PARAMETERS, parameter_unit
from ._format import esc, pretty_unit, squared

PAIR_POINTS = 800
PAGE_DPI = 96
"""Resolution of a figure on the page."""
FILE_DPI = 110
"""Resolution of a figure written as a file (``discover --out``)."""
_POSITIVE = {name for name, p in PARAMETERS.items() if p.link in ("log", "log_logit")}
"""Parameters drawn on a log axis: the scales (and time constants) of the noise terms."""


def png(figure, dpi: int = PAGE_DPI, tight: bool = False) -> bytes:
    """The figure as PNG bytes, drawn by the Agg canvas attached to it alone."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(figure)
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=dpi, bbox_inches="tight" if tight else None)
    return buffer.getvalue()


def embedded(figure, alt: str) -> str:
    """The figure as an ``<img>`` of the page, its PNG inline (the page opens offline)."""
    encoded = base64.b64encode(png(figure)).decode("ascii")
    return f'<img class="figure" alt="{esc(alt)}" src="data:image/png;base64,{encoded}">'


def new_figure(width: float, height: float, panels: int = 1):
    """A figure of ``panels`` axes side by side, laid out by matplotlib's constrained
    layout."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(width, height), layout="constrained")
    axes = figure.subplots(1, panels, squeeze=False)[0]
    return figure, list(axes)


def _log_axes(axes, xlabel: str, ylabel: str, title: str, fontsize: float | None = None):
    axes.set_xscale("log")
    axes.set_yscale("log")
    axes.set_xlabel(xlabel)
    axes.set_ylabel(ylabel)
    axes.set_title(title, fontsize=fontsize)
    axes.grid(True, which="both", lw=0.3, alpha=0.6)
    axes.legend(fontsize=7.5, loc="best")


# ---------------------------------------------------------------------------------------------
# The noise of a channel


def allan_figure(channel: str, unit: str, allan, band=None, check=None):
    """The measured Allan deviation (``allan``, a :class:`~bayescal.DeviationResult`) with
    its classical bars and, with a posterior, its bands (an
    :class:`~bayescal.inference._bands.AllanBand`) and the bounds of the model's Allan
    deviation check (``check``, a :class:`~bayescal.FitCheck`: outside them a point fails
    it; the bands are pointwise 90 %, which about one point in ten leaves by chance)."""
    shown = pretty_unit(unit)
    percent = f"{100 * allan.confidence:g} %"
    figure, (axes,) = new_figure(7.2, 4.4)
    tau, deviation = np.asarray(allan.tau), np.asarray(allan.deviation)
    usable = np.isfinite(deviation)
    if check is not None and check.curve.get("check_low"):
        curve = check.curve
        for edge, label in (
            (curve["check_low"], "the fit check's bounds (a point outside fails it)"),
            (curve["check_high"], None),
        ):
            axes.plot(curve["tau_s"], edge, color="#08519c", lw=0.9, ls="--", label=label)
    if band is not None:
        level = f"{100 * band.level:g} %"
        axes.fill_between(
            band.tau_s,
            band.predictive_low,
            band.predictive_high,
            color="#9ecae1",
            alpha=0.45,
            lw=0,
            label=f"posterior predictive of the measured ADEV ({level})",
        )
        axes.fill_between(
            band.fine_tau_s,
            band.fine_expected_low,
            band.fine_expected_high,
            color="#3182bd",
            alpha=0.55,
            lw=0,
            label=f"model's exact ADEV over posterior draws ({level})",
        )
        axes.plot(
            band.fine_tau_s,
            band.fine_expected_median,
            color="#08519c",
            lw=1.2,
            label="model, posterior median",
        )
    low = np.asarray(allan.ci_low)[usable]
    high = np.asarray(allan.ci_high)[usable]
    centre = deviation[usable]
    axes.errorbar(
        tau[usable],
        centre,
        yerr=[np.maximum(centre - low, 0), np.maximum(high - centre, 0)],
        fmt="o",
        ms=3.5,
        color="black",
        ecolor="#444444",
        capsize=2,
        lw=1,
        label=f"measured (overlapping), classical {percent} chi-square bars",
    )
    _log_axes(
        axes, "averaging time τ [s]", f"Allan deviation [{shown}]", f"{channel}: Allan deviation"
    )
    return figure


def spectrum_figure(channel: str, unit: str, band, lines=()):
    """The binned periodogram against the model's (a
    :class:`~bayescal.inference._bands.SpectrumBand`), with the spectral lines taken out of
    the record fitted (their frequencies, Hz) marked."""
    level = f"{100 * band.level:g} %"
    figure, (axes,) = new_figure(7.2, 4.4)
    frequency = band.frequency_hz
    axes.fill_between(
        frequency,
        band.predictive_low,
        band.predictive_high,
        color="#fdae6b",
        alpha=0.45,
        lw=0,
        label=f"posterior predictive of the binned periodogram ({level})",
    )
    axes.fill_between(
        frequency,
        band.expected_low,
        band.expected_high,
        color="#e6550d",
        alpha=0.6,
        lw=0,
        label=f"model spectrum over posterior draws ({level})",
    )
    axes.plot(
        frequency,
        band.measured_asd,
        ".",
        ms=2.5,
        color="black",
        label="measured (binned periodogram, 2 % bins)",
    )
    axes.plot(
        frequency, band.expected_median, color="#a63603", lw=1.2, label="model, posterior median"
    )
    for index, line in enumerate(lines):
        axes.axvline(
            line,
            color="#3182bd",
            lw=0.8,
            ls="--",
            label="spectral lines (taken out of the record fitted)" if index == 0 else None,
        )
    _log_axes(
        axes,
        "frequency [Hz]",
        f"amplitude spectral density [{pretty_unit(unit)}/√Hz]",
        f"{channel}: spectrum (two-sided; white noise reads N)",
    )
    return figure


def pair_figure(channel: str, unit: str, fit):
    """Every pair of the sampled parameters of ``fit`` (a noise posterior), the noise scales
    on log axes."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import MaxNLocator

    names = ["bias", *fit.problem.parameters]
    sample = draw_subset(fit, PAIR_POINTS, 7)
    size = len(names)
    figure = Figure(figsize=(1.9 * size + 0.8, 1.9 * size + 0.6))
    grid = figure.subplots(size, size, squeeze=False)
    inch = 1.0 / (1.9 * size + 0.8)
    figure.subplots_adjust(
        left=0.75 * inch,
        bottom=0.6 * inch,
        right=0.98,
        top=1 - 0.35 * inch,
        wspace=0.08,
        hspace=0.08,
    )
    values = {}
    for name in names:
        draw = sample[name]
        values[name] = np.log10(draw) if name in _POSITIVE and np.all(draw > 0) else draw
    for row, y_name in enumerate(names):
        for column, x_name in enumerate(names):
            axes = grid[row][column]
            if column > row:
                axes.set_axis_off()
                continue
            if column == row:
                axes.hist(values[x_name], bins=30, color="#3182bd", alpha=0.8)
            else:
                axes.plot(
                    values[x_name],
                    values[y_name],
                    ".",
                    ms=1.5,
                    alpha=0.35,
                    color="#08519c",
                    rasterized=True,
                )
            axes.tick_params(labelsize=6.5)
            axes.xaxis.set_major_locator(MaxNLocator(3))
            axes.yaxis.set_major_locator(MaxNLocator(4))
            if column == row:
                axes.set_yticks([])
            if row == size - 1:
                axes.set_xlabel(_pair_label(x_name, unit), fontsize=7.5)
            else:
                axes.set_xticklabels([])
            if column == 0 and row > 0:
                axes.set_ylabel(_pair_label(y_name, unit), fontsize=7.5)
            elif column != row:
                axes.set_yticklabels([])
    figure.suptitle(f"{channel}: posterior pairs ({sample['bias'].size} draws)", fontsize=10)
    return figure


def _pair_label(name: str, unit: str) -> str:
    shown = pretty_unit(parameter_unit(name, unit))
    if name in _POSITIVE:
        return f"log10 {name} [{shown}]"
    return f"{name} [{shown}]"


# ---------------------------------------------------------------------------------------------
# Discovery: the baseline model beside the final one


def _stages(found: bool, before, after):
    """The panels of a before/after figure: both when an effect was found, else the baseline
    alone (the final model is the baseline)."""
    if not found:
        return [("baseline model (nothing found)", before)]
    return [("before: baseline model", before), ("after: final model", after)]


def _check_band(axes, tau, low, high, label: str) -> None:
    """A check's bounds on an Allan figure: a point outside them fails the check."""
    if len(low):
        axes.fill_between(
            tau[: len(low)], low, high, color="#c6dbef", alpha=0.8, lw=0, label=label, zorder=0
        )


CHECK_BAND_LABEL = "the check's bounds (a point outside fails it; p < 0.01 over all τ)"


def discovery_allan_figure(channel: str, unit: str, curves, found: bool):
    """The Allan deviation of each model's residual within that model's bands (``curves``:
    a discovery's :class:`~bayescal.report._discovery.AllanCurves`): before, the recording
    against the baseline model; after, the recording less the terms discovery added against
    the final model. The lighter band is the check's (a point outside it fails the Allan
    deviation check, whose p-value is Bonferroni-corrected over the taus); the darker one the
    model's pointwise 90 % band, which about one point in ten leaves by chance."""
    stages = _stages(
        found,
        (
            curves.adev,
            curves.baseline_low,
            curves.baseline_high,
            curves.baseline_check_low,
            curves.baseline_check_high,
            "recording",
        ),
        (
            curves.final_adev,
            curves.final_low,
            curves.final_high,
            curves.final_check_low,
            curves.final_check_high,
            "recording less the added deterministic terms",
        ),
    )
    figure, panels = new_figure(4.2 * len(stages) + 0.4, 3.8, len(stages))
    tau_all = np.asarray(curves.tau_s)
    for axes, (title, (measured, low, high, check_low, check_high, label)) in zip(
        panels, stages, strict=True
    ):
        _check_band(axes, tau_all, check_low, check_high, CHECK_BAND_LABEL)
        if len(low):
            axes.fill_between(
                tau_all[: len(low)],
                low,
                high,
                color="#4292c6",
                alpha=0.7,
                lw=0,
                label="model's 90 % band (pointwise)",
            )
        axes.plot(tau_all[: len(measured)], measured, "o-", ms=3, lw=1, color="black", label=label)
        _log_axes(
            axes, "τ [s]", f"Allan deviation [{pretty_unit(unit)}]", f"{channel}: {title}", 9.5
        )
    return figure


def discovery_spectrum_figure(channel: str, unit: str, curves, found: bool):
    """The binned periodogram of the increments against each model's expected one
    (``curves``: :class:`~bayescal.report._discovery.SpectrumCurves`)."""
    stages = _stages(
        found,
        (curves.power, curves.baseline_model, "recording (increments, binned)"),
        (curves.final_power, curves.final_model, "recording less the deterministic terms"),
    )
    figure, panels = new_figure(4.2 * len(stages) + 0.4, 3.8, len(stages))
    frequency = np.asarray(curves.frequency_hz)
    positive = frequency > 0
    for axes, (title, (measured, model, label)) in zip(panels, stages, strict=True):
        axes.plot(
            frequency[positive],
            np.asarray(measured)[positive],
            ".",
            ms=2,
            color="#555555",
            label=label,
        )
        axes.plot(
            frequency[positive], np.asarray(model)[positive], color="#e6550d", lw=1.4, label="model"
        )
        _log_axes(
            axes,
            "frequency [Hz]",
            f"periodogram of the increments [{squared(unit)}]",
            f"{channel}: {title}",
            9.5,
        )
    return figure


def discovery_residual_figure(channel: str, unit: str, curves, found: bool):
    """Block means of each model's residual over time (``curves``:
    :class:`~bayescal.report._discovery.ResidualCurves`)."""
    figure, (axes,) = new_figure(6.4, 4.2)
    axes.plot(curves.time_s, curves.baseline, "r.-", label="baseline residual")
    if found:
        axes.plot(curves.time_s, curves.final, "b.-", label="final residual")
    axes.axhline(0, color="k", lw=0.5)
    axes.set_xlabel("time [s]")
    axes.set_ylabel(f"block mean of residual [{pretty_unit(unit)}]")
    axes.set_title(f"{channel}: residual over time")
    axes.grid(True, lw=0.3, alpha=0.6)
    axes.legend(fontsize=7.5)
    return figure


def discovery_temperature_figure(channel: str, unit: str, curves, found: bool):
    """Block means of each model's residual against the temperature's (``curves``:
    :class:`~bayescal.report._discovery.TemperatureCurves`)."""
    figure, (axes,) = new_figure(6.4, 4.2)
    axes.plot(curves.temperature, curves.baseline, "r.", label="baseline residual")
    if found:
        axes.plot(curves.temperature, curves.final, "b.", label="final residual")
    axes.axhline(0, color="k", lw=0.5)
    axes.set_xlabel(f"temperature [{pretty_unit(curves.temperature_unit)}]")
    axes.set_ylabel(f"block mean of residual [{pretty_unit(unit)}]")
    axes.set_title(f"{channel}: residual against temperature")
    axes.grid(True, lw=0.3, alpha=0.6)
    axes.legend(fontsize=7.5)
    return figure


def discovery_distribution_figure(channel: str, unit: str, curves, found: bool):
    """Histogram of the samples as recorded and with the clipped ones imputed, beside the
    fitted unclipped normal and the rails (``curves``:
    :class:`~bayescal.report._discovery.DistributionCurves`)."""
    edges = curves.edges
    figure, (axes,) = new_figure(6.4, 4.2)
    axes.stairs(curves.recorded, edges, color="tab:red", label="as recorded")
    axes.stairs(curves.unclipped, edges, color="tab:blue", label="clipped samples imputed")
    axes.stairs(curves.expected, edges, color="k", ls="--", label="unclipped normal")
    for rail in curves.rails:
        axes.axvline(rail, color="0.4", lw=0.8)
    axes.set_yscale("log")
    axes.set_ylim(0.5, None)
    axes.set_xlabel(f"sample value [{pretty_unit(unit)}] (rail: grey line)")
    axes.set_ylabel("samples per bin")
    axes.set_title(f"{channel}: distribution at the rail")
    axes.legend(fontsize=7.5)
    return figure


DISCOVERY_FIGURES = {
    "allan": (discovery_allan_figure, "Allan deviation before and after"),
    "spectrum": (discovery_spectrum_figure, "spectrum before and after"),
    "residual_time": (discovery_residual_figure, "residual over time"),
    "residual_temperature": (discovery_temperature_figure, "residual against temperature"),
    "distribution": (discovery_distribution_figure, "distribution at the rail"),
}
"""Discovery's figures by name (the file name's suffix of ``discover --out``), each with what
it shows; a discovery has the curves of the last two only with a temperature or a rail."""


# ---------------------------------------------------------------------------------------------
# The in-field update (``bayescal thermal infield --report``)

NINETY = 1.6448536269514722
"""The 95 % point of the standard normal: a Gaussian's central 90 % band is mean +- this sd."""
CHI2_2_90 = -2 * np.log(0.1)
"""The 90 % point of chi^2 with 2 dof: the 90 % ellipse of a 2-D Gaussian."""
LEG_COLOURS = ("#3182bd", "#e6550d", "#31a354", "#756bb1", "#d6616b", "#8c6d31")


def infield_track_figure(track: dict, taxi: dict | None):
    """The computed (free-inertial) track, east against north, m (``track``: the
    :attr:`~bayescal.InFieldUpdate.track`): the park's steps, the taxi's, the steps on each
    known leg in that leg's colour, each leg's known track heading drawn through its first
    and last step used (a computed track off that line carries the heading error the taxi
    tells), and the position fixes the filter measured, where a position reference was given
    (``track["fixes"]``: the computed track drifts from them by the heading error times the
    distance run)."""
    north, east = np.asarray(track["north"]), np.asarray(track["east"])
    leg, park = np.asarray(track["leg"]), int(track["park_steps"])
    unit = pretty_unit(track["unit"])
    figure, (axes,) = new_figure(7.2, 5.0)
    fixes = track.get("fixes")
    if fixes is not None:
        axes.plot(
            np.asarray(fixes["east"]),
            np.asarray(fixes["north"]),
            "x",
            color="#636363",
            ms=3,
            mew=0.6,
            alpha=0.7,
            label=f"position fixes ({len(fixes['north'])}; north and east of the first)",
        )
    axes.plot(east[:park], north[:park], ".", color="0.3", ms=3, label="the park (still)")
    if taxi is not None:
        axes.plot(east[park:], north[park:], "-", color="0.65", lw=1, label="the taxi, computed")
        for index, heading in enumerate(taxi["track_heading_deg"]):
            on = np.flatnonzero(leg == index)
            colour = LEG_COLOURS[index % len(LEG_COLOURS)]
            if on.size == 0:
                continue
            axes.plot(
                east[on],
                north[on],
                ".",
                color=colour,
                ms=3,
                label=f"steps used on the {heading:g}° leg ({on.size})",
            )
            # The known heading through the leg's first step used, as long as the steps run.
            direction = np.array([np.cos(np.radians(heading)), np.sin(np.radians(heading))])
            start = np.array([north[on[0]], east[on[0]]])
            run = (np.stack([north[on], east[on]], axis=1) - start) @ direction
            ends = start + np.outer([run.min(), run.max()], direction)
            axes.plot(
                ends[:, 1],
                ends[:, 0],
                "--",
                color=colour,
                lw=1.2,
                label=f"known track {heading:g}°",
            )
    axes.set_aspect("equal", adjustable="datalim")
    axes.set_xlabel(f"east of the start [{unit}]")
    axes.set_ylabel(f"north of the start [{unit}]")
    axes.set_title(
        "the park and the taxi: computed track" if taxi else "the park: computed position",
        fontsize=9,
    )
    axes.grid(True, lw=0.3, alpha=0.6)
    axes.legend(fontsize=7.5, loc="best")
    return figure


def infield_points_figure(
    classical: dict, scales: dict, unit: str, heading_deg, temperature_unit: str
):
    """Each gyro's classical points (the patent's tilt rates block by block, projected on it):
    temperature against bias with its sd, before and after the heading error's Earth-rate
    equivalent (``heading_deg``, None when no taxi told it) is taken off (steps m-n).
    ``scales``: channel -> the factor from its unit to ``unit``."""
    axes_of = classical["axes"]
    figure, panels = new_figure(3.2 * len(axes_of) + 0.6, 3.6, len(axes_of))
    shown = pretty_unit(unit)
    for axes, (name, entry) in zip(panels, axes_of.items(), strict=True):
        scale, rows = scales[name], entry["points"]
        temperature = np.array([row["temperature"] for row in rows])
        sd = scale * np.array([row["sd"] for row in rows])
        before = scale * np.array([row["bias_before_heading"] for row in rows])
        after = scale * np.array([row["bias"] for row in rows])
        axes.errorbar(
            temperature,
            before,
            yerr=sd,
            fmt="o",
            mfc="none",
            color="0.45",
            capsize=2,
            ms=5,
            label="before the heading correction",
        )
        if heading_deg is not None:
            axes.errorbar(
                temperature,
                after,
                yerr=sd,
                fmt="o",
                color="#3182bd",
                capsize=2,
                ms=4,
                label="after",
            )
        _gyro_bias_axes(axes, name, temperature_unit, shown)
    panels[0].legend(fontsize=7, loc="best")
    title = (
        f"the tilt-rate points, ±1 sd: before and after {heading_deg:.4g}° of heading error "
        "is taken off"
        if heading_deg is not None
        else "the tilt-rate points, ±1 sd (no taxi told the heading: nothing taken off)"
    )
    figure.suptitle(title, fontsize=9)
    return figure


def _gyro_bias_axes(axes, name: str, temperature_unit: str, shown: str) -> None:
    """One gyro's panel of bias against temperature: its labels, title and grid."""
    axes.set_xlabel(f"temperature [{pretty_unit(temperature_unit)}]")
    axes.set_ylabel(f"{name} bias [{shown}]")
    axes.set_title(name, fontsize=9)
    axes.grid(True, lw=0.3, alpha=0.6)


def infield_calibration_figure(old: dict, new: dict, points: dict, scales: dict, unit: str):
    """Each gyro's old and updated calibration over the updated one's calibrated range, with
    their Gaussian 90 % bands (:meth:`~bayescal.ThermalCalibration.bias`), and the smoother's
    points the update saw (its bias per block, ±1 sd). ``scales``: channel -> the factor from
    its unit to ``unit``."""
    figure, panels = new_figure(3.2 * len(new) + 0.6, 3.6, len(new))
    shown = pretty_unit(unit)
    for axes, (name, updated) in zip(panels, new.items(), strict=True):
        scale = scales[name]
        low, high = updated.temperature_range
        grid = np.linspace(low, high, 121)
        for label, calibration, colour in (
            ("old", old[name], "0.45"),
            ("updated", updated, "#3182bd"),
        ):
            mean, sd = calibration.bias(grid)
            axes.fill_between(
                grid,
                scale * (mean - NINETY * sd),
                scale * (mean + NINETY * sd),
                color=colour,
                alpha=0.25,
                lw=0,
            )
            axes.plot(grid, scale * mean, color=colour, lw=1.3, label=f"{label} (90 % band)")
        seen = points[name]
        axes.errorbar(
            seen["temperature"],
            scale * np.asarray(seen["bias"]),
            yerr=scale * np.asarray(seen["sd"]),
            fmt="o",
            color="black",
            ms=3.5,
            capsize=2,
            label="the alignment's points (±1 sd)",
        )
        _gyro_bias_axes(axes, name, updated.temperature_unit, shown)
    panels[0].legend(fontsize=7, loc="best")
    return figure


def infield_drift_figure(errors: dict):
    """The horizontal position error after free inertial navigation, as the posterior predicts
    it (:meth:`~bayescal.InFieldUpdate.position_error`), one panel per flight (``errors``:
    flight -> {"old": ..., "updated": ...}): each calibration's predicted mean error (north,
    east) and its 90 % ellipse."""
    figure, panels = new_figure(3.6 * len(errors) + 0.6, 3.9, len(errors))
    angle = np.linspace(0, 2 * np.pi, 181)
    circle = np.sqrt(CHI2_2_90) * np.stack([np.cos(angle), np.sin(angle)])
    for axes, (flight, by_calibration) in zip(panels, errors.items(), strict=True):
        for label, colour in (("old", "0.45"), ("updated", "#3182bd")):
            error = by_calibration[label]
            mean = np.asarray(error["mean"])
            ellipse = mean[:, None] + np.linalg.cholesky(np.asarray(error["covariance"])) @ circle
            axes.plot(ellipse[1], ellipse[0], color=colour, lw=1.2)
            axes.plot(
                mean[1],
                mean[0],
                "o",
                color=colour,
                label=f"{label}: mean {np.hypot(*mean):.3g} m from zero, sd {error['sd']:.3g} m",
            )
        axes.plot(0, 0, "+", color="black", ms=10)
        hours = by_calibration["updated"]["duration_s"] / 3600
        axes.set_title(f"{flight}, after {hours:g} h", fontsize=9)
        axes.set_xlabel("east error [m]")
        axes.set_ylabel("north error [m]")
        axes.set_aspect("equal", adjustable="datalim")
        axes.grid(True, lw=0.3, alpha=0.6)
        axes.legend(fontsize=7, loc="best")
    figure.suptitle("predicted position error: mean and 90 % ellipse", fontsize=9)
    return figure
