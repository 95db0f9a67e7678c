"""``bayescal discover``: locate, name and model what a baseline model of a static channel
left out (:mod:`bayescal._discover`), with the JSON contract of the discovery issue."""

import sys

import numpy as np

from ._errors import InputError

DEFAULT_BASELINE = "white"


def add_parser(commands) -> None:
    from ._cli import _add_recording_arguments

    parser = commands.add_parser(
        "discover",
        help="find the physics a model left out: locate the mismatch, name it, model it",
    )
    _add_recording_arguments(parser)
    parser.add_argument(
        "--baseline",
        default=DEFAULT_BASELINE,
        metavar="TERMS",
        help="noise terms of the starting model besides the bias (default: white, the model "
        "behind the classical pad numbers), e.g. white,bias_instability",
    )
    parser.add_argument(
        "--sim",
        metavar="FILE",
        help="a recording made by your own simulator (same channel name): what it holds "
        "becomes the baseline, and discovery reports what the real recording holds beyond it",
    )
    parser.add_argument(
        "--temperature", metavar="COL", help="temperature column (default: found by name)"
    )
    parser.add_argument(
        "--max-effects", type=int, default=4, metavar="N", help="stop after N effects (4)"
    )
    parser.add_argument("--json", metavar="PATH", help="write the findings as JSON")
    parser.add_argument(
        "--out", metavar="DIR", help="figures before/after and the final posterior (netCDF)"
    )
    parser.add_argument(
        "--seed",
        type=int,
        default=0,
        help="seed of the posterior sampler (and of the imputation of clipped samples)",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress messages")
    parser.set_defaults(run=run)


def _temperature_column(table, given):
    from ._thermal_command import find_temperature_column

    if given:
        return find_temperature_column(table, given)
    try:
        return find_temperature_column(table, None)
    except InputError:
        return None


def read_discovery_data(path, args, channel: str):
    """The channel, its temperature and accelerometer columns on the channel's grid."""
    from ._cli import _window
    from ._discover import DiscoveryData
    from ._pad import find_accelerometer_columns
    from ._recording import load_table, prepare_channel, resolve_unit

    table = load_table(path, topic=getattr(args, "topic", None))
    start, stop, _ = _window(args, table)
    temperature = _temperature_column(table, args.temperature)
    data = prepare_channel(
        table,
        channel,
        unit=args.unit,
        rate=args.rate,
        time_column=args.time_column,
        time_unit=args.time_unit,
        start=start,
        stop=stop,
        gaps=args.gaps,
        temperature=temperature,
    )
    covariates, covariate_units = {}, {}
    accelerometers = find_accelerometer_columns(table)
    if data.unit in ("deg/s", "rad/s", "deg/h") and accelerometers:
        for name in accelerometers:
            column = prepare_channel(
                table,
                name,
                rate=args.rate,
                time_column=args.time_column,
                time_unit=args.time_unit,
                start=start,
                stop=stop,
                gaps=args.gaps,
            )
            if column.values.size == data.values.size:
                covariates[name] = column.values
                covariate_units[name] = resolve_unit(table, name, None)[0]
    temperature_values = data.temperature
    if (
        temperature_values is not None
        and np.ptp(temperature_values[np.isfinite(temperature_values)]) == 0
    ):
        temperature_values = None
    return DiscoveryData(
        values=data.values,
        rate_hz=data.rate_hz,
        channel=data.channel,
        unit=data.unit,
        temperature=temperature_values,
        covariates=covariates,
        covariate_units=covariate_units,
        notes=data.notes,
    ), data


def _check_json(check: dict, after: dict | None) -> dict:
    entry = {key: check[key] for key in ("name", "statistic", "p_value", "location", "passed")}
    entry["passed_before"] = entry.pop("passed")
    entry["passed_after"] = after["passed"] if after else entry["passed_before"]
    if after:
        entry["p_value_after"] = after["p_value"]
    return entry


def discovery_result(result, posterior, *, baseline_terms, source: str, sim: dict | None) -> dict:
    """The JSON document (the contract of the discovery issue, with more keys)."""
    from ._discover import (
        AMBIGUOUS_LOG_BAYES_FACTOR,
        DECISIVE_LOG_BAYES_FACTOR,
        EXPLANATIONS,
        UNMODELLED_CHECKS,
        effect_parameters,
    )
    from ._mcmc import summarize
    from ._output import to_jsonable

    after = {check["name"]: check for check in result.final_checks}
    failed_before = [c["name"] for c in result.baseline_checks if not c["passed"]]
    effects = []
    for finding in result.findings:
        evidence = {
            "log_bayes_factor": finding.log_bayes_factor,
            "decisive_above": DECISIVE_LOG_BAYES_FACTOR,
            "baseline_checks_failed": failed_before,
            "checks_passed_after": [
                name for name in failed_before if after.get(name, {}).get("passed")
            ],
        }
        explanation = EXPLANATIONS[finding.name]
        if finding.runner_up:
            runner, runner_score = finding.runner_up
            evidence["runner_up"] = {"name": runner, "log_bayes_factor": runner_score}
            if finding.log_bayes_factor - runner_score < AMBIGUOUS_LOG_BAYES_FACTOR:
                evidence["indistinguishable_from"] = runner
                explanation += (
                    f" On this recording it cannot be told from {runner} (log Bayes factor "
                    f"{finding.log_bayes_factor - runner_score:.1f} between them, below log 10): "
                    "both explain the mismatch; a longer recording would decide."
                )
        if finding.name == "outliers" and result.outliers:
            evidence["fraction"] = result.outliers["fraction"]
            evidence["flagged_samples"] = int(result.outliers["flagged"].sum())
        if finding.name == "saturation" and result.saturation:
            evidence["rails"] = {
                side: {**rail, "unit": result.data.unit}
                for side, rail in result.saturation["rails"].items()
            }
            values = result.data.values
            evidence["unclipped_mean"] = result.saturation["mean"]
            evidence["unclipped_sd"] = result.saturation["sd"]
            evidence["clipped_mean"] = float(np.nanmean(values))
            evidence["clipped_sd"] = float(np.nanstd(values))
            evidence["unit"] = result.data.unit
        effects.append(
            {
                "name": finding.name,
                "explanation": explanation,
                "location": _location(finding, result),
                "evidence": evidence,
                "delta_elpd": finding.delta_elpd,
                "delta_elpd_se": finding.delta_elpd_se,
                "parameters": effect_parameters(finding.name, finding, posterior, result.data)
                if posterior
                else {},
            }
        )
    document = {
        "channel": result.data.channel,
        "unit": result.data.unit,
        "source": source,
        "rate_hz": result.data.rate_hz,
        "duration_s": result.data.duration_s,
        "baseline": ["bias", *baseline_terms],
        "effects": effects,
        "final_terms": result.final.spec.terms(),
        "checks": [
            _check_json(check, after.get(check["name"]) if result.findings else None)
            for check in result.baseline_checks
        ],
        "decision_rule": "a term is accepted when its Schwarz (BIC) log Bayes factor against "
        "the current model exceeds log(100) = 4.6 (decisive); delta_elpd is the AIC-penalised "
        "gain in log predictive density, pointwise over independent frequency bins of the "
        "increments and one-block-ahead predictions of 128 block means, with its standard "
        "error; saturation and outliers are decided first, on the samples' distribution "
        "(censored and contaminated normal against the normal), at the same threshold",
    }
    still_failing = [
        check["name"]
        for check in result.final_checks
        if not check["passed"] and check["name"] not in UNMODELLED_CHECKS
    ]
    if still_failing and result.undecided:
        name, score = result.undecided
        document["unexplained"] = {
            "checks": still_failing,
            "best_candidate": name,
            "log_bayes_factor": score,
            "decisive_above": DECISIVE_LOG_BAYES_FACTOR,
            "explanation": f"a mismatch remains ({', '.join(still_failing)}); the term that "
            f"would explain it best, {name}, is not decisive (log Bayes factor {score:.1f}): "
            "the recording holds too little evidence to name it — record longer, or with more "
            "of what the term needs (a wider temperature swing, a start from power-on).",
        }
    if posterior is not None:
        document["posterior"] = {
            "parameters": {
                name: summarize(values, posterior.units[name])
                for name, values in posterior.draws.items()
            },
            "health": posterior.diagnostics.as_dict(),
        }
    if sim is not None:
        document["simulation"] = sim
    from ._discover_figures import diagnostics

    document["diagnostics"] = diagnostics(result)
    return to_jsonable(document)


def _location(finding, result) -> dict:
    """Where the accepted effect was located: the baseline check that points to it."""
    checks = {check["name"]: check for check in result.baseline_checks}
    pointer = {
        "thermal_bias": "residual_vs_temperature",
        "sinusoid": "spectral_line",
        "warmup_transient": "residual_time",
        "rate_ramp": "residual_time",
        "outliers": "tails",
        "saturation": "rail",
        "quantization": "discrete_levels",
    }.get(finding.name, "allan_deviation")
    if finding.name == "g_sensitivity":
        pointer = f"residual_vs_{finding.fit.spec.g_sensitivity[-1]}"
    if finding.name == "sinusoid":
        return {"check": pointer, "frequency_hz": finding.fit.spec.sinusoid_hz[-1]}
    location = dict(checks[pointer]["location"]) if pointer in checks else {}
    location["check"] = pointer
    return location


def discovery_text(document: dict) -> str:
    lines = [
        f"discovery on {document['channel']} ({document['unit']}), "
        f"{document['duration_s']:.0f} s at {document['rate_hz']:g} Hz",
        f"baseline: {', '.join(document['baseline'])}",
    ]
    if not document["effects"]:
        lines.append("nothing missing: no term improves the fit decisively")
    for number, effect in enumerate(document["effects"], 1):
        lines.append(
            f"{number}. {effect['name']}: log Bayes factor "
            f"{effect['evidence']['log_bayes_factor']:.1f}, delta ELPD "
            f"{effect['delta_elpd']:.1f} ± {effect['delta_elpd_se']:.1f}"
        )
        lines.append(f"   {effect['explanation']}")
        if effect["name"] == "saturation":
            evidence = effect["evidence"]
            for side, rail in evidence["rails"].items():
                lines.append(
                    f"   {side} rail {rail['value']:.6g} {rail['unit']}: {rail['samples']} samples"
                )
            lines.append(
                f"   unclipped mean {evidence['unclipped_mean']:.6g} {evidence['unit']}, sd "
                f"{evidence['unclipped_sd']:.4g} (as recorded: {evidence['clipped_mean']:.6g}, "
                f"{evidence['clipped_sd']:.4g})"
            )
        for name, value in effect["parameters"].items():
            if "q05" in value:
                lines.append(
                    f"   {name} = {value['mean']:.4g} [{value['q05']:.4g}, {value['q95']:.4g}] "
                    f"{value['unit']} (90 %)"
                )
    lines.append(f"final model: {', '.join(document['final_terms'])}")
    if "unexplained" in document:
        lines.append(f"still unexplained: {document['unexplained']['explanation']}")
    for check in document["checks"]:
        mark = "ok" if check["passed_after"] else "MISMATCH"
        before = "ok" if check["passed_before"] else "failed"
        lines.append(f"   check {check['name']:<28} before: {before:<7} after: {mark}")
    return "\n".join(lines)


def findings_for_report(table, data, *, seed: int = 0, baseline=("white",)) -> dict:
    """Discovery on one prepared channel of ``table`` (its temperature column found by name),
    as the JSON document: what ``bayescal report --discover`` and the demo put on the page."""
    from ._discover import DiscoveryData, discover, sample_final

    temperature = None
    column = _temperature_column(table, None)
    if column is not None:
        from ._recording import prepare_channel

        temperature = prepare_channel(table, data.channel, temperature=column).temperature
        if temperature.size != data.values.size or np.ptp(temperature) == 0:
            temperature = None
    discovery_data = DiscoveryData(
        values=data.values,
        rate_hz=data.rate_hz,
        channel=data.channel,
        unit=data.unit,
        temperature=temperature,
        notes=data.notes,
    )
    result = discover(discovery_data, baseline=tuple(baseline), seed=seed)
    posterior = sample_final(result.final, discovery_data, seed=seed) if result.findings else None
    return discovery_result(
        result, posterior, baseline_terms=list(baseline), source=table.source, sim=None
    )


def _simulation_baseline(args, channel) -> tuple[tuple[str, ...], dict]:
    """Discover on the user's simulation from white noise: what it holds is the baseline."""
    from ._discover import NOISE_EFFECTS, discover

    data, _ = read_discovery_data(args.sim, args, channel)
    found = discover(data, max_effects=args.max_effects)
    terms = ["white", *[f.name for f in found.findings if f.name in NOISE_EFFECTS]]
    others = [f.name for f in found.findings if f.name not in NOISE_EFFECTS]
    return tuple(terms), {
        "file": args.sim,
        "terms_found": ["bias", *terms, *others],
        "note": "the simulation's noise terms are the baseline; deterministic terms found in "
        "the simulation are listed but not carried over",
    }


def run(args) -> int:
    from ._cli import _output_folder
    from ._discover import TERM_SLOT, discover, sample_final
    from ._output import check_writable, write_json

    if not args.file:
        raise InputError("no recording given", fix="pass a FILE")
    if not args.channel:
        raise InputError("--channel is required", source=args.file, fix="e.g. --channel gyro_x")
    if args.max_effects < 1:
        raise InputError(f"--max-effects {args.max_effects} must be at least 1")
    if args.json:
        check_writable(args.json, "--json")
    folder = _output_folder(args.out)
    baseline = tuple(part.strip() for part in args.baseline.split(",") if part.strip())
    unknown = [term for term in baseline if term not in TERM_SLOT]
    if unknown:
        raise InputError(
            f"--baseline: unknown term(s) {', '.join(unknown)}",
            fix=f"use terms among {', '.join(sorted(TERM_SLOT))}",
        )
    sim = None
    if args.sim:
        baseline, sim = _simulation_baseline(args, args.channel)
    data, _ = read_discovery_data(args.file, args, args.channel)
    talk = (lambda m: print(f"discover: {m}", file=sys.stderr)) if not args.quiet else None
    result = discover(
        data,
        baseline=baseline or ("white",),
        max_effects=args.max_effects,
        progress=talk,
        seed=args.seed,
    )
    posterior = sample_final(result.final, data, seed=args.seed) if result.findings else None
    baseline_terms = list(dict.fromkeys(("white", *baseline)))
    document = discovery_result(
        result, posterior, baseline_terms=baseline_terms, source=str(args.file), sim=sim
    )
    if folder is not None:
        from ._discover_figures import write_folder

        write_folder(folder, result, posterior, document)
    if args.json:
        write_json(args.json, document)
    print(discovery_text(document))
    if posterior is not None and not posterior.diagnostics.passed:
        print(
            "bayescal discover: HEALTH CHECK FAILED for the final posterior: "
            + "; ".join(posterior.diagnostics.failures),
            file=sys.stderr,
        )
        return 1
    return 0
