"""The noise of one static channel, classical and Bayesian side by side: what ``bayescal
noise`` and each channel of the report render (:class:`NoiseAnalysis`), its JSON document
(:func:`noise_document`) and the table ``bayescal noise`` prints (:func:`noise_text`).

One home each: the analysis holds the typed results (the classical block, the
:class:`~bayescal.NoiseFit`, the window it was read in, the notes); the document, the text
and the page (:mod:`._html`) read it; what two of them show beyond its attributes (where a
reading was taken, why the t-interval fails, where classical and Bayesian disagree) is
written once, here.
"""

import math
from dataclasses import dataclass
from functools import cached_property
from importlib.metadata import version
from typing import TYPE_CHECKING

# A classical reading's units come from its IEEE 952 line (its time power), a posterior's
# from the registry of terms, imported where a posterior is reported: the registry loads JAX
# (about 1 s), which a classical-only run never needs.
from ..classical._noise import IEEE952_READINGS, ClassicalNoise, SlopeReading
from ..recording._units import datasheet_values, time_scaled_unit

if TYPE_CHECKING:  # the Bayesian modules load only for a Bayesian result (--classical-only)
    from ..capabilities._noise import NoiseFit
    from ..inference._noise_posterior import NoisePosterior

INTERVAL = 0.90
"""Probability of every posterior interval shown (5 % and 95 % quantiles)."""
BIAS_DEFINITION = "turn-on bias: the expected reading at the start of the window"


@dataclass(frozen=True)
class Window:
    """The stretch of the recording analysed, s, how it was chosen (``selected_by``: whole
    record, start/stop, pad) and what the choice found (a pad window's liftoff ...)."""

    start_s: float
    stop_s: float
    selected_by: str = "whole record"
    details: dict | None = None
    """More of how it was chosen (the pad search's liftoff, level and columns), as the JSON
    holds it."""

    @classmethod
    def described(cls, description: dict) -> tuple["Window", tuple[str, ...]]:
        """The window the command line describes (``start_s``, ``stop_s``, ``selected_by`` and
        what a pad search found), and the notes it carries."""
        details = dict(description)
        start_s, stop_s = details.pop("start_s"), details.pop("stop_s")
        selected_by = details.pop("selected_by", "whole record")
        notes = tuple(details.pop("notes", ()))
        return cls(start_s, stop_s, selected_by, details or None), notes

    def as_dict(self) -> dict:
        return {
            "start_s": self.start_s,
            "stop_s": self.stop_s,
            "selected_by": self.selected_by,
            **(self.details or {}),
        }


@dataclass(frozen=True)
class NoiseAnalysis:
    """The noise of one channel as ``bayescal noise`` and the report show it: the classical
    numbers, the posterior beside them (None: classical only), where the channel comes from
    and the window it was read in, with the notes gathered on the way."""

    source: str
    channel: str
    unit: str
    window: Window
    classical: ClassicalNoise
    noise: "NoiseFit | None" = None
    notes: tuple[str, ...] = ()
    """The window's notes, the channel's and the fit's, then any the caller adds."""

    @classmethod
    def of(cls, data, classical, window: Window, noise=None, notes=(), extra_notes=()):
        """The analysis of ``data`` (a Channel or a NoiseFit: its source, name, unit and
        notes), the window's ``notes`` first and ``extra_notes`` last."""
        return cls(
            source=data.source,
            channel=data.channel,
            unit=data.unit,
            window=window,
            classical=classical,
            noise=noise,
            notes=(*notes, *data.notes, *extra_notes),
        )

    @property
    def fit(self) -> "NoisePosterior | None":
        """The posterior itself (None: classical only)."""
        return None if self.noise is None else self.noise.fit

    @cached_property
    def comparison(self) -> list[str]:
        """Where classical and Bayesian disagree beyond their uncertainties, and why."""
        if self.noise is None:
            return []
        return comparison_notes(self.classical, self.noise.fit, self.unit)


def read_at(reading: SlopeReading) -> str:
    """Where a reading was taken, in words: the stretch of the curve it came from."""
    if reading.kind == "upper_bound":
        return f"upper bound, tightest at tau = {reading.tau_s:.3g} s: {reading.reason}"
    return reading.where


def _reading(parameter: str, reading: SlopeReading, unit: str) -> dict:
    time_power = IEEE952_READINGS[parameter].time_power
    unit_of_parameter = time_scaled_unit(unit, time_power)
    return {
        "value": reading.value,
        "ci_low": reading.ci_low,
        "ci_high": reading.ci_high,
        "unit": unit_of_parameter,
        "kind": reading.kind,
        "tau_s": reading.tau_s,
        "local_slope": reading.local_slope,
        "read_at": read_at(reading),
        "display": {
            label: {
                "value": value,
                "ci_high": datasheet_values(reading.ci_high, unit, time_power)[label],
            }
            for label, value in datasheet_values(reading.value, unit, time_power).items()
        },
    }


def t_interval_explanation(classical: ClassicalNoise) -> str:
    """Why the Student-t interval of the bias holds, or by how much it is too narrow."""
    check = classical.t_interval
    interval = f"interval {check.ratio_ci_low:.2f}-{check.ratio_ci_high:.2f}"
    if check.valid and check.ratio_ci_high < 1.0:
        return (
            f"conservative: the Allan deviation at tau = {check.tau_s:g} s is "
            f"{check.ratio:.2f}x the white-noise prediction ({interval} lies below 1): "
            "neighbouring samples are anti-correlated at that scale (an output filter, "
            "quantization), so the Student-t interval is wider than it need be"
        )
    if check.valid:
        return (
            f"consistent with independent samples: the Allan deviation at tau = "
            f"{check.tau_s:g} s is {check.ratio:.2f}x the white-noise prediction "
            f"({interval} includes 1)"
        )
    return (
        f"samples are correlated: the Allan deviation at tau = {check.tau_s:g} s is "
        f"{check.ratio:.2f}x (interval {check.ratio_ci_low:.2f}-{check.ratio_ci_high:.2f}) "
        f"what independent samples would give, so the Student-t interval is too narrow by "
        f"about that factor"
    )


def display_summary(name: str, summary, unit: str) -> dict[str, dict[str, float]]:
    """A posterior summary of noise parameter ``name`` (its mean, q05 and q95: attributes or
    keys) in the units datasheets use: label -> {mean, q05, q95}; empty for the bias or a unit
    bayescal does not know."""
    from ..models._terms import TERM_OF_PARAMETER, display_values

    if name not in TERM_OF_PARAMETER:
        return {}
    values = {
        key: summary[key] if isinstance(summary, dict) else getattr(summary, key)
        for key in ("mean", "q05", "q95")
    }
    return {
        label: {key: display_values(name, values[key], unit)[label] for key in values}
        for label in display_values(name, values["mean"], unit)
    }


def _bayesian_block(fit: "NoisePosterior", unit: str) -> dict:
    from ..inference._mcmc import ACCEPTANCE_RANGE, AUTOCORR_MULTIPLE, MAX_RHAT, MIN_ESS
    from ..models._terms import TERM_OF_PARAMETER, parameter_unit

    parameters = {}
    for name, summary in fit.parameters.items():
        unit_of_parameter = parameter_unit(name, unit)
        entry = {
            "mean": summary.mean,
            "sd": summary.sd,
            "q05": summary.q05,
            "q95": summary.q95,
            "map": summary.map,
            "map_sd": summary.map_sd,
            "unit": unit_of_parameter,
        }
        if name in TERM_OF_PARAMETER:
            entry["term"] = TERM_OF_PARAMETER[name]
            entry["display"] = display_summary(name, summary, unit)
        parameters[name] = entry
    diagnostics = fit.diagnostics.as_dict()
    diagnostics["sampler"] = "emcee ensemble, differential-evolution moves"
    diagnostics["criteria"] = {
        "max_rhat": MAX_RHAT,
        "min_ess_bulk": MIN_ESS,
        "acceptance_fraction": list(ACCEPTANCE_RANGE),
        "steps_per_autocorrelation_time": AUTOCORR_MULTIPLE,
    }
    return {
        "terms": list(fit.terms),
        "prior": fit.problem.prior.description,
        "bias_definition": BIAS_DEFINITION,
        "interval": INTERVAL,
        "seed": fit.seed,
        "parameters": parameters,
        "diagnostics": diagnostics,
    }


def comparison_notes(classical: ClassicalNoise, fit: "NoisePosterior", unit: str) -> list[str]:
    """Where the classical numbers and the posterior disagree beyond their uncertainties,
    and why."""
    from ..models._terms import TERM_OF_PARAMETER, TERMS, parameter_unit

    notes = []
    bias = fit.parameters["bias"]
    t_sd = (
        (classical.bias_ci_high - classical.bias_ci_low)
        / 2
        / _normal_quantile(classical.confidence)
    )
    ratio = bias.sd / t_sd
    slow = [
        f"{name} = {fit.parameters[name].mean:.3g} {parameter_unit(name, unit)}"
        for name in (TERMS[term].parameter for term in fit.terms if TERMS[term].band == "low")
    ]
    if ratio > 2:
        why = (
            f"the model lets the bias wander ({', '.join(slow)})"
            if slow
            else "the model's output filter correlates neighbouring samples"
        )
        notes.append(
            f"bias: the posterior's uncertainty is {ratio:.3g}x the Student-t "
            f"interval's: {why}, which the t-interval, treating the samples as "
            "independent, ignores"
        )
    if abs(bias.mean - classical.bias) > 2 * math.hypot(bias.sd, t_sd):
        notes.append(
            f"bias: the turn-on bias {bias.mean:.6g} {unit} and the sample mean "
            f"{classical.bias:.6g} {unit} disagree beyond their uncertainties: the "
            "bias moved during the record, and the mean is its average"
        )
    for name, reading in classical.slope_readings.items():
        if name not in fit.parameters:
            continue
        posterior = fit.parameters[name]
        unit_of_parameter = parameter_unit(name, unit)
        if reading.kind == "upper_bound":
            if posterior.q05 > reading.ci_high:
                # Read beyond the output filter's reach (classical._noise), the bound no
                # longer errs by construction; which side errs is for the fit checks to say.
                notes.append(
                    f"{name}: the posterior (5 % quantile {posterior.q05:.3g} "
                    f"{unit_of_parameter}) lies above the bound the Allan curve allows at "
                    f"tau = {reading.tau_s:.3g} s ({reading.ci_high:.3g}): either the record's "
                    "averages there run low by chance (the classical interval rests on a noise "
                    "type identified from few averages), or the model's "
                    f"{name} is carried by higher frequencies than the record's slow noise "
                    "holds; the model's Allan and spectrum checks, at its own degrees of "
                    "freedom, are the test of the second"
                )
            continue
        if reading.ci_low > posterior.q95 or reading.ci_high < posterior.q05:
            notes.append(
                f"{name}: classical {reading.value:.3g} [{reading.ci_low:.3g}, "
                f"{reading.ci_high:.3g}] and Bayesian {posterior.mean:.3g} "
                f"[{posterior.q05:.3g}, {posterior.q95:.3g}] {unit_of_parameter} disagree "
                f"beyond their uncertainties: {TERMS[TERM_OF_PARAMETER[name]].classical_caveat}"
            )
    return notes


def _normal_quantile(confidence: float) -> float:
    from scipy import special

    return float(special.ndtri(0.5 + confidence / 2))


def noise_document(analysis: NoiseAnalysis) -> dict:
    """The JSON document of ``bayescal noise`` (contract in docs/guide/outputs.md): the
    classical block, and with a posterior the Bayesian one with its checks against the record
    and how its terms were chosen."""
    classical, unit = analysis.classical, analysis.unit
    allan = classical.allan
    widened_low, widened_high = classical.widened_interval
    result = {
        "bayescal_version": version("bayescal"),
        "source": analysis.source,
        "channel": analysis.channel,
        "unit": unit,
        "n_samples": classical.n_samples,
        "rate_hz": classical.rate_hz,
        "duration_s": classical.duration_s,
        "window": analysis.window.as_dict(),
        "notes": list(analysis.notes),
        "classical": {
            "bias": {
                "value": classical.bias,
                "ci_low": classical.bias_ci_low,
                "ci_high": classical.bias_ci_high,
                "confidence": classical.confidence,
                "unit": unit,
                "method": "sample mean, Student-t interval",
                "widened_ci_low": widened_low,
                "widened_ci_high": widened_high,
            },
            "std": {"value": classical.std, "unit": unit},
            "t_interval_valid": classical.t_interval.valid,
            "t_interval_widening": classical.t_interval.widening,
            "t_interval_check": {
                "adev_ratio": classical.t_interval.ratio,
                "adev_ratio_ci_low": classical.t_interval.ratio_ci_low,
                "adev_ratio_ci_high": classical.t_interval.ratio_ci_high,
                "tau_s": classical.t_interval.tau_s,
                "explanation": t_interval_explanation(classical),
            },
            "allan": {
                "estimator": "overlapping Allan deviation (NIST SP 1065 eq. 11)",
                "tau_s": allan.tau,
                "adev": allan.deviation,
                "ci_low": allan.ci_low,
                "ci_high": allan.ci_high,
                "confidence": allan.confidence,
                "n_terms": allan.n,
                "edf": allan.edf,
                "noise_alpha": allan.alpha,
                "unit": unit,
            },
            "slope_readings": {
                parameter: _reading(parameter, reading, unit)
                for parameter, reading in classical.slope_readings.items()
            },
        },
    }
    noise = analysis.noise
    if noise is not None:
        bayesian = result["bayesian"] = _bayesian_block(noise.fit, unit)
        if noise.selection is not None:
            bayesian["term_selection"] = {
                "method": "Laplace evidence, forward then backward from white noise",
                "threshold_log_bayes_factor": noise.selection.threshold,
                "candidates": noise.selection.table,
            }
        if noise.lsb > 0:
            bayesian["rounding"] = {
                "lsb": noise.lsb,
                "unit": unit,
                "white_floor": _white_floor(noise),
                "output_white_level": noise.output_white_level,
                "density_unit": time_scaled_unit(unit, IEEE952_READINGS["N"].time_power),
                "explanation": "the samples sit on a grid of this step: their rounding error "
                "(LSB^2/12 per sample) is a known white floor in the model, so N is the "
                "sensor's white noise without it; the output's white level adds it back",
            }
        if noise.lines is not None:
            bayesian["spectral_lines"] = noise.lines.as_dict()
        bayesian["fit_checks"] = [check.as_dict() for check in noise.checks]
        bayesian["fits"] = noise.fits
        bayesian["comparison"] = analysis.comparison
    return result


def _white_floor(noise: "NoiseFit") -> float:
    """The rounding's white floor, LSB / sqrt(12 fs), unit/√Hz."""
    return noise.lsb / math.sqrt(12 * noise.rate_hz)


def _number(value: float) -> str:
    return "n/a" if value is None else f"{value:.5g}"


def noise_text(analysis: NoiseAnalysis) -> str:
    """The table ``bayescal noise`` prints."""
    classical, unit, window = analysis.classical, analysis.unit, analysis.window
    percent = f"{100 * classical.confidence:g}%"
    lines = [
        f"bayescal noise: {analysis.source}, channel {analysis.channel} [{unit}]",
        f"  {classical.n_samples} samples at {classical.rate_hz:.6g} Hz, "
        f"{classical.duration_s:.6g} s (window {window.start_s:.6g}-{window.stop_s:.6g} s, "
        f"{window.selected_by})",
        "",
        f"  bias          {_number(classical.bias)} {unit}   {percent} Student-t interval "
        f"[{_number(classical.bias_ci_low)}, {_number(classical.bias_ci_high)}]",
        f"  std           {_number(classical.std)} {unit}",
    ]
    explanation = t_interval_explanation(classical)
    if classical.t_interval.valid:
        lines.append(f"  t-interval    valid: {explanation}")
    else:
        low, high = classical.widened_interval
        lines.append(f"  t-interval    NOT VALID: {explanation}")
        lines.append(
            f"                widened x{classical.t_interval.widening:.3g}: "
            f"[{_number(low)}, {_number(high)}] {unit}"
        )
    allan = classical.allan
    lines += [
        "",
        f"  Allan deviation (overlapping), {100 * allan.confidence:g}% chi-square "
        "intervals (Greenhall EDF)",
        f"  {'tau [s]':>12} {'ADEV [' + unit + ']':>18} {'low':>12} {'high':>12} {'alpha':>6}",
    ]
    for tau, dev, low, high, alpha in zip(
        allan.tau, allan.deviation, allan.ci_low, allan.ci_high, allan.alpha, strict=True
    ):
        lines.append(
            f"  {tau:>12.5g} {_number(dev):>18} {_number(low):>12} {_number(high):>12} {alpha:>6}"
        )
    lines += ["", "  IEEE 952 slope readings"]
    for parameter, reading in classical.slope_readings.items():
        lines.append(_reading_line(parameter, reading, unit))
    if analysis.noise is not None:
        lines += _side_by_side(analysis)
    if analysis.notes:
        lines += ["", "  notes:"] + [f"  - {note}" for note in analysis.notes]
    return "\n".join(lines)


def frequency_text(frequency: dict) -> str:
    """A line's frequency to the digits its standard error resolves (Hz): two lines the
    record tells apart print apart."""
    sd = frequency["sd"]
    decimals = max(1, math.ceil(-math.log10(sd)) + 1) if sd > 0 else 6
    return f"{frequency['mean']:.{decimals}f} ± {sd:.1g} Hz"


def lines_text(block: dict | None, unit: str) -> list[str]:
    """The rows of the spectral lines' table (``bayesian.spectral_lines`` of the document)."""
    if not block:
        return []
    found = block["lines"]
    test = block["test"]
    head = (
        f"  spectral lines: {len(found)} found (periodogram test, family-wise "
        f"{100 * test['family_wise_level']:g} % over {test['frequencies_searched']:,} "
        f"frequencies; resolution {test['resolution_hz']:.3g} Hz); N is the floor between them"
    )
    rows = [head] if found else [head.replace(": 0 found", ": none found")]
    for line in found:
        amplitude = line["amplitude"]
        kind = (
            f"broadened, {line['width_hz']:.3g} Hz wide, power {_number(line['power']['mean'])} "
            f"{line['power']['unit']}"
            if line["kind"] == "broadened"
            else "sinusoid"
        )
        aliased = (
            f"; aliased: the output filter passes {100 * line['filter_gain']:.2g} % of the power "
            "there"
            if line["aliased"]
            else ""
        )
        rows.append(
            f"    {frequency_text(line['frequency']):<28} amplitude "
            f"{_number(amplitude['mean'])} [{_number(amplitude['q05'])}, "
            f"{_number(amplitude['q95'])}] {unit}, {line['ratio_to_floor']:.3g}x the floor "
            f"({kind}{aliased})"
        )
    return rows


def _reading_line(parameter: str, reading: SlopeReading, unit: str) -> str:
    """An IEEE 952 reading as a line of the table, with its datasheet units."""
    time_power = IEEE952_READINGS[parameter].time_power
    unit_of_parameter = time_scaled_unit(unit, time_power)
    if reading.kind == "upper_bound":
        shown, value = f"<= {_number(reading.ci_high)} {unit_of_parameter}", reading.ci_high
    else:
        shown, value = f"{_number(reading.value)} {unit_of_parameter}", reading.value
    extra = "".join(
        f" = {_number(converted)} {label}"
        for label, converted in datasheet_values(value, unit, time_power).items()
    )
    return f"  {parameter}  {shown}{extra}   ({read_at(reading)})"


def _side_by_side(analysis: NoiseAnalysis) -> list[str]:
    """The classical and Bayesian columns of ``bayescal noise``, the posterior's checks and
    where the two disagree.

    Over 80 lines: the table's blocks in the order printed (the terms chosen, the rounding,
    the parameters, their datasheet units, the sampler's checks, the fit's)."""
    from ..models._terms import parameter_unit

    classical, noise, unit = analysis.classical, analysis.noise, analysis.unit
    fit = noise.fit
    percent = f"{100 * classical.confidence:g}%"
    lines = [
        "",
        f"  classical ({percent} intervals) and Bayesian (posterior mean, 90% interval; "
        f"MAP +- Laplace sd); terms: {', '.join(fit.terms)}",
    ]
    if noise.selection is not None:
        lines.append(
            f"  terms chosen by evidence (kept at log BF >= {noise.selection.threshold:.2f}):"
        )
        lines += [f"    {trial.term:<20}{trial.reason}" for trial in noise.selection.trials]
    if noise.lsb > 0:
        lines.append(
            f"  samples on a grid of {_number(noise.lsb)} {unit}: rounding's "
            f"white floor {_number(_white_floor(noise))} {parameter_unit('N', unit)} kept "
            f"out of N (output's white level {_number(noise.output_white_level)})"
        )
    lines += lines_text(None if noise.lines is None else noise.lines.as_dict(), unit)
    width = 2 + max(6, *(len(name) for name in fit.parameters))
    lines.append(f"  {'':{width}}{'unit':<16}{'classical':<38}{'Bayesian':<40}MAP")
    readings = classical.slope_readings
    for name, summary in fit.parameters.items():
        if name == "bias":
            shown = (
                f"{_number(classical.bias)} [{_number(classical.bias_ci_low)}, "
                f"{_number(classical.bias_ci_high)}]"
            )
        elif name in readings:
            reading = readings[name]
            shown = (
                f"<= {_number(reading.ci_high)}"
                if reading.kind == "upper_bound"
                else f"{_number(reading.value)} [{_number(reading.ci_low)}, "
                f"{_number(reading.ci_high)}]"
            )
        else:
            shown = "-"
        posterior = f"{_number(summary.mean)} [{_number(summary.q05)}, {_number(summary.q95)}]"
        lines.append(
            f"  {name:<{width}}{parameter_unit(name, unit):<16}{shown:<38}{posterior:<40}"
            f"{_number(summary.map)} +- {_number(summary.map_sd)}"
        )
    for name, summary in fit.parameters.items():
        for label, shown in display_summary(name, summary, unit).items():
            lines.append(
                f"  {name:<{width}}{label:<16}{'':<38}{_number(shown['mean'])} "
                f"[{_number(shown['q05'])}, {_number(shown['q95'])}]"
            )
    diagnostics = fit.diagnostics
    if diagnostics.passed:
        lines.append(
            f"  posterior checks passed: {diagnostics.n_steps} steps x "
            f"{diagnostics.n_walkers} walkers, autocorrelation time <= "
            f"{max(diagnostics.autocorr_time.values()):.0f}, ESS >= "
            f"{min(diagnostics.ess_bulk.values()):.0f}, R-hat <= "
            f"{max(diagnostics.rhat.values()):.3f}, acceptance "
            f"{diagnostics.acceptance_fraction:.2f}"
        )
    else:
        lines.append("  POSTERIOR CHECKS FAILED — do not use these Bayesian numbers:")
        lines += [f"    - {failure}" for failure in diagnostics.failures]
    if noise.fits:
        lines.append(
            "  the model fits the record: "
            + ", ".join(check.name.replace("_", " ") for check in noise.checks)
            + " within the model's band"
        )
    else:
        lines.append("  MODEL MISFIT — the model does not describe this record:")
        lines += [f"    - {check.misfit}" for check in noise.checks if check.misfit]
        lines.append(
            "    see bayescal discover for what the model leaves out"
            + ("" if noise.selection is not None else ", or let the record choose: --terms auto")
        )
    if analysis.comparison:
        lines += ["", "  where they disagree:"] + [f"  - {note}" for note in analysis.comparison]
    return lines
