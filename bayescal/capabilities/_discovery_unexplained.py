"""What discovery leaves unexplained, described for a user (:func:`unexplained_of`): each
check the final model still fails, located in time and/or frequency, with what it looks like
(a step, a stretch, a late drift, switching levels, a burst, a step of the noise level, a
line, a band), its size, and the advice that follows from what was seen — never advice the
record contradicts (recording longer where it already holds many cycles of the band)."""

from ..inference._discovery_search import (
    DECISIVE_LOG_BAYES_FACTOR,
    HIGH_FREQUENCY_FRACTION,
    SearchResult,
    check_band,
)
from ..models.effects.sinusoid import SAME_LINE_BINS, Sinusoid, harmonic_family

ENOUGH_CYCLES = 10
"""A record that holds this many cycles of the slowest frequency (or averaging times) where a
mismatch was located is not advised to be recorded longer: what is left is in the shape of
the data, not their amount."""


def _slowest_period(check: dict) -> float | None:
    """The longest period (1 / frequency, or averaging time) a check located its mismatch at,
    s; None where it located none."""
    where = check["location"]
    if check["name"] == "spectrum_bands":
        return 1.0 / where["frequency_hz"][0]
    if check["name"] == "spectral_line":
        return 1.0 / where["frequency_hz"]
    if check["name"] == "allan_deviation" and "tau_s" in where:
        return max(where.get("tau_range_s", [where["tau_s"]]))
    return None


def _fundamental(frequency: float, withdrawn_hz: tuple, duration_s: float) -> tuple | None:
    """(fundamental, harmonic): where the line at ``frequency`` (Hz) and a sinusoid the
    search withdrew (``withdrawn_hz``: it left a line of its own family failing) are one
    frequency and a whole multiple of the other, within :data:`SAME_LINE_BINS` resolutions
    (1 / ``duration_s``): the harmonics of one periodic waveform that is not a sine (a
    sawtooth, a controller's cycle), the lower the fundamental; None otherwise."""
    for line in withdrawn_hz:
        family = harmonic_family(frequency, line, duration_s)
        if family is not None:
            low, _ = family
            return low, round(frequency / low)
    return None


def _mismatch(
    check: dict,
    rate_hz: float,
    duration_s: float,
    in_time: bool,
    lines_hz: tuple = (),
    withdrawn_hz: tuple = (),
) -> dict:
    """One failing check of the final model described for a user: where (time and/or
    frequency), what it looks like, how large, and what to do about it. ``in_time``: a scan
    located a departure in time, which is then what a slow mismatch of the spectrum or the
    Allan deviation is (not too little data). ``lines_hz``: the sinusoids' frequencies the
    search named (Hz); a line left within :data:`SAME_LINE_BINS` resolutions (1 / duration)
    of one is the only line a longer record is advised for (it would separate the two).
    ``withdrawn_hz``: the sinusoids it withdrew; a line of one's harmonic family is a
    periodic waveform that is not a sine (:func:`_fundamental`), reported at its
    fundamental with no sinusoid named."""
    name, where = check["name"], check["location"]
    entry = {"check": name, "band": check_band(check, rate_hz), "p_value": check["p_value"]}
    slowest_s = _slowest_period(check)
    short = (slowest_s is None or ENOUGH_CYCLES * slowest_s > duration_s) and not in_time
    match name:
        case "level_scan":
            shape, time_s, size = where["shape"], where["time_s"], where["size"]
            entry |= {"shape": shape, "time_s": time_s, "size": size, "unit": where["unit"]}
            if shape == "switching levels":
                times = ", ".join(f"{event['time_s']}" for event in where["events"][:6])
                entry["advice"] = (
                    f"the level switches between values (near {times} s): popcorn "
                    "(random telegraph) noise of a part, or a mode that toggles; look at the "
                    "level over time, and analyse the stretches apart"
                )
            elif shape == "step":
                entry["advice"] = (
                    f"the level stepped by {size:.3g} {where['unit']} at {time_s:.6g} s: look "
                    "for a mode change, a power glitch or a knock at that time, and analyse "
                    "the parts before and after apart"
                )
            elif shape == "stretch":
                entry["advice"] = (
                    f"the level departed by {size:.3g} {where['unit']} between "
                    f"{time_s[0]:.6g} and {time_s[1]:.6g} s: something acted on the sensor "
                    "then (handling, a temperature transient); cut the stretch out or "
                    "analyse it apart"
                )
            else:
                entry["advice"] = (
                    f"a drift of {size:.3g} {where['unit']} began at {time_s:.6g} s: look "
                    "for what changed then (a heater, a scale factor that changed under a "
                    "slow input, a temperature controller)"
                )
        case "variance_scan":
            shape, time_s = where["shape"], where["time_s"]
            ratio, band = where["variance_ratio"], where["band_hz"]
            bandwidth = "broadband" if where["broadband"] else f"{band[0]:.3g}-{band[1]:.3g} Hz"
            entry |= {
                "shape": shape,
                "time_s": time_s,
                "variance_ratio": ratio,
                "frequency_hz": band,
                "broadband": where["broadband"],
            }
            if shape == "burst":
                entry["advice"] = (
                    f"the noise power was {ratio:.3g}x the rest's ({bandwidth}) between "
                    f"{time_s[0]:.6g} and {time_s[1]:.6g} s, longer than a burst of the "
                    "catalogue: vibration or handling then; cut that stretch out"
                )
            else:
                entry["advice"] = (
                    f"the noise power changed by {ratio:.3g}x ({bandwidth}) at {time_s:.6g} s "
                    "and stayed: the sensor's mode, supply or mounting changed then (or its "
                    "time stamps: jitter shows as noise); analyse the parts apart"
                )
        case "spectral_line" if _fundamental(where["frequency_hz"], withdrawn_hz, duration_s):
            frequency = where["frequency_hz"]
            fundamental, harmonic = _fundamental(frequency, withdrawn_hz, duration_s)
            entry |= {
                "shape": "periodic waveform",
                "frequency_hz": frequency,
                "fundamental_hz": fundamental,
                "harmonic": harmonic,
            }
            entry["advice"] = (
                f"a periodic waveform that is not a sine: a line at {frequency:.6g} Hz "
                f"(harmonic {harmonic}) of a fundamental at {fundamental:.6g} Hz (period "
                f"{1 / fundamental:.4g} s), whose sinusoid explained its own line but left "
                "its harmonics: a sawtooth or a switching controller's cycle (a thermostat, "
                "a heater's duty cycle); look for a source with that period, and fit its "
                "waveform (a sum of its harmonics), not one sinusoid"
            )
        case "spectral_line":
            frequency = where["frequency_hz"]
            entry |= {"shape": "line", "frequency_hz": frequency}
            entry["advice"] = (
                f"a line at {frequency:.6g} Hz that the catalogue's sinusoids do not explain "
                "(more lines than they take, harmonics of a periodic signal that is not a "
                "sine — a sawtooth, a switching controller — or a line that wanders): look "
                "for a periodic source at that frequency and its multiples"
                + (
                    f"; it lies within {SAME_LINE_BINS:g} resolutions "
                    f"({1 / duration_s:.3g} Hz) of a fitted sinusoid: a longer record "
                    "separates the two"
                    if any(
                        abs(frequency - line) <= SAME_LINE_BINS / duration_s for line in lines_hz
                    )
                    else ""
                )
            )
        case "spectrum_bands" | "allan_deviation":
            if name == "spectrum_bands":
                entry |= {
                    "shape": "band power",
                    "frequency_hz": where["frequency_hz"],
                    "power_over_model": where["power_over_model"],
                }
            else:
                entry |= {
                    "shape": "Allan deviation",
                    "tau_s": where.get("tau_range_s", where.get("tau_s")),
                    "adev_over_model": where.get("adev_over_model"),
                }
            if entry["band"] == "low" and in_time:
                entry["advice"] = (
                    "the departure the level or variance scan located in time shows here "
                    "too: see its entry"
                )
            elif entry["band"] == "high":
                entry["advice"] = (
                    "toward Nyquist the sensor's output filter, its rounding and aliasing "
                    "from a faster internal rate shape the spectrum, and no shape of the "
                    "catalogue explains it: check the part's configured bandwidth and output "
                    "rate; a record with the filter bypassed tells the shapes apart"
                )
            elif short:
                entry["advice"] = (
                    "the recording holds too little evidence to name it: record longer, or "
                    "with more of what a term needs (a wider temperature swing, a start from "
                    "power-on)"
                )
            else:
                entry["advice"] = (
                    "the record is long, so this is its shape, not too little data: the "
                    "noise differs from every stationary term of the catalogue there (a "
                    "sawtooth or a controller's cycle, time-stamp jitter, a process the "
                    "catalogue lacks)"
                )
        case "tails":
            entry |= {"shape": "tails", "location": where}
            entry["advice"] = (
                "more samples lie far out than the model's Gaussian noise gives, and not as "
                "the isolated glitches of the catalogue (runs of them, or too many): look at "
                "the samples at the times given (handling, a loose connector, a digital "
                "fault) and cut those stretches out"
            )
        case "residual_time" if in_time:
            entry |= {"shape": name, "location": where}
            entry["advice"] = "the level scan's entry locates it: see there"
        case _:
            entry |= {"shape": name, "location": where}
            entry["advice"] = (
                "see the check's location"
                if not short
                else "record longer, or with more of what the check needs"
            )
    return entry


def _located_band(checks: list[dict], failing: list[str], rate_hz: float) -> tuple[str, str]:
    """The band the failing checks located the mismatch in, and where, in words: a time (the
    level or the variance scan); a spectral line; high frequency (spectrum bands or Allan
    deviation only near Nyquist); else low."""
    located = {check["name"]: check["location"] for check in checks if check["name"] in failing}
    for name in ("level_scan", "variance_scan"):
        if name in located:
            time_s = located[name]["time_s"]
            at = (
                f"{time_s[0]:.6g}-{time_s[1]:.6g} s"
                if isinstance(time_s, list)
                else f"{time_s:.6g} s"
            )
            shape = located[name]["shape"]
            article = "" if shape == "switching levels" else "a "
            return ("low" if name == "level_scan" else "noise"), f"{article}{shape} at {at}"
    if "spectral_line" in located:
        return "line", f"a line at {located['spectral_line']['frequency_hz']:.6g} Hz"
    if set(located) == {"tails"}:
        times = located["tails"].get("times_s", [])[:6]
        return "samples", "samples far out" + (
            f" at {', '.join(f'{t:.6g}' for t in times)} s" if times else ""
        )
    high = (
        [
            f"{low:.3g}-{top:.3g} Hz"
            for low, top in [located["spectrum_bands"]["frequency_hz"]]
            if low >= HIGH_FREQUENCY_FRACTION * rate_hz
        ]
        if "spectrum_bands" in located
        else []
    )
    allan = located.get("allan_deviation", {})
    longest = max(allan.get("tau_range_s", [allan.get("tau_s", 0.0)]))
    slow = set(located) - {"spectrum_bands", "allan_deviation"}
    if high and not slow and longest <= 1.0 / (HIGH_FREQUENCY_FRACTION * rate_hz):
        return "high", f"located at {high[0]}"
    where = []
    if "spectrum_bands" in located:
        low, top = located["spectrum_bands"]["frequency_hz"]
        where.append(f"spectrum {low:.3g}-{top:.3g} Hz")
    if allan:
        where.append(f"Allan deviation at tau = {allan['tau_s']:.3g} s")
    return "low", ", ".join(where) or "in the slow residual"


def unexplained_of(result: SearchResult, still_failing: list[str]) -> dict:
    """What the final model leaves unexplained: each failing check located and described
    (:func:`_mismatch`), the findings withdrawn because they did not explain it, those left
    out because their log Bayes factor and ELPD gain disagree (both numbers given), and the
    best candidate where none was decisive."""
    data = result.data
    in_time = bool({"level_scan", "variance_scan"} & set(still_failing))
    lines_hz, withdrawn_hz = (
        tuple(
            finding.effect.frequency_hz
            for finding in findings
            if isinstance(finding.effect, Sinusoid)
        )
        for findings in (result.findings, result.withdrawn)
    )
    mismatches = [
        _mismatch(check, data.rate_hz, data.duration_s, in_time, lines_hz, withdrawn_hz)
        for check in result.final_checks
        if check["name"] in still_failing
    ]
    band, where = _located_band(result.final_checks, still_failing, data.rate_hz)
    if not still_failing:  # only a finding whose evidence disagrees: its band is the place
        band = result.disagreeing[0].effect.band
        where = f"where {result.disagreeing[0].name} acts (its evidence disagrees)"
    unexplained = {
        "checks": still_failing,
        "band": band,
        "where": where,
        "mismatches": mismatches,
        "withdrawn": [
            {"name": finding.name, "log_bayes_factor": finding.log_bayes_factor}
            for finding in result.withdrawn
        ],
        "decisive_above": DECISIVE_LOG_BAYES_FACTOR,
    }
    told = []
    if result.withdrawn:
        names = ", ".join(finding.name for finding in result.withdrawn)
        told.append(
            f"{names} absorbed part of it with decisive evidence but left its checks failing: "
            "not named (the nearest catalogue entry is not the physics)"
        )
    if result.disagreeing:
        unexplained["disagreeing"] = [
            {
                "name": finding.name,
                "log_bayes_factor": finding.log_bayes_factor,
                "delta_elpd": finding.delta_elpd,
                "delta_elpd_se": finding.delta_elpd_se,
            }
            for finding in result.disagreeing
        ]
        told += [
            f"{finding.name} had a decisive log Bayes factor ({finding.log_bayes_factor:+.1f}) "
            f"but predicts worse (ELPD gain {finding.delta_elpd:+.1f} +- "
            f"{finding.delta_elpd_se:.1f} nats): the evidence disagrees with itself, so it is "
            "not named"
            for finding in result.disagreeing
        ]
    if result.undecided:
        name, score = result.undecided.name, result.undecided.log_bayes_factor
        unexplained["best_candidate"] = name
        unexplained["log_bayes_factor"] = score
        located = result.undecided.against
        if located is not None:
            unexplained["against"] = {
                "shape": located.shape,
                "time_s": located.start_s
                if located.shape == "drift"
                else [located.start_s, located.stop_s],
            }
            told.append(
                f"{name} absorbs it with decisive evidence against the model without it, but "
                f"not against the {located.shape} the level scan located (log Bayes factor "
                f"{score:.1f} against it): a one-off departure there, not a {name}"
            )
        else:
            told.append(
                f"the term that would explain it best, {name}, is not decisive (log Bayes "
                f"factor {score:.1f})"
            )
    advice = "; ".join(dict.fromkeys(entry["advice"] for entry in mismatches))
    unexplained["explanation"] = (
        f"a mismatch no catalogue entry explains remains ({', '.join(still_failing) or '-'}; "
        f"{where})" + (": " + "; ".join(told) if told else "") + f". {advice}"
    )
    return unexplained
