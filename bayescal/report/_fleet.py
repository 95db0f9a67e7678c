"""A fleet's population as the JSON document of ``bayescal fleet`` (:func:`fleet_result`),
the text it prints (:func:`fleet_text`) and its page (:func:`fleet_page`): the population
with each unit's interval beside it, the specification's verdict, the units the population
does not predict, the recordings left out, where the work ran. All three read the
:class:`~bayescal.FleetFit` (its :attr:`~bayescal.FleetFit.summary` for the figures with
their intervals), never the document.

JSON keys (the contract the checks read; ../shared/DESIGN.md "Fleets"):
``population.<param>.median`` and ``population.<param>.log_sd`` for each noise scale in the
population, ``population.bias.unit_to_unit_sd`` and ``population.bias.run_to_run_sd``, each
``{mean, q05, q95, unit}`` (90 % intervals; null with a ``note`` where the fleet cannot
identify it); ``units.<id>.<param>``; ``spec`` (when limits were given); ``compute``.
"""

import datetime
from importlib.metadata import version

import numpy as np

from ..capabilities._fleet import FleetFit
from ..inference._mcmc import ACCEPTANCE_RANGE, AUTOCORR_MULTIPLE, MAX_RHAT, MIN_ESS
from ..inference._population import MIN_POINT_ESS, RESOLVED_LOG_SD
from ..models._population import BIAS_SD_PRIOR_FACTOR, LOG_SD_PRIOR_SCALE
from ..models._terms import parameter_unit
from ._figures import embedded, new_figure
from ._format import esc, interval, num, page_start, pretty_unit

_NAMES = {"N": "N white noise", "B": "B bias instability", "K": "K rate random walk"}


def _recording_entry(recording) -> dict:
    return {
        "row": recording.row,
        "source": recording.source,
        "unit": recording.unit,
        "run": recording.run,
        "n_samples": recording.n_samples,
        "rate_hz": recording.rate_hz,
        "temperature_c": recording.temperature_c,
        "seed": recording.seed,
        "task_s": recording.seconds,
        "checks": recording.checks,
        "posterior": {
            p: {
                "mean": float(np.mean(np.exp(draws))),
                "q05": float(np.exp(np.quantile(draws, 0.05))),
                "q95": float(np.exp(np.quantile(draws, 0.95))),
                "unit": parameter_unit(p, recording.channel_unit),
            }
            for p, draws in recording.log_draws.items()
        },
        "notes": list(recording.notes),
    }


def spec_verdict(spec: dict | None) -> list[str]:
    """The specification's verdict, one line per limit and one for all of them, e.g.
    ``P(N < 0.3 deg/sqrt(h)) = 0.93 [0.85, 0.97]`` (posterior mean [90 % interval]) for the
    next unit of the population; with one unit, that unit's probability."""
    if not spec:
        return []
    if spec["all"]["next_unit"] is None:
        return [
            f"P(unit {unit} meets {limit['label']}) = {limit['units'][unit]:.2f}"
            for limit in spec["limits"]
            for unit in limit["units"]
        ] + [
            f"P(unit {unit} meets all limits) = {p:.2f}" for unit, p in spec["all"]["units"].items()
        ]

    def shown(entry):
        return f"{entry['mean']:.2f} [{entry['q05']:.2f}, {entry['q95']:.2f}]"

    lines = [f"P({limit['label']}) = {shown(limit['next_unit'])}" for limit in spec["limits"]]
    if len(spec["limits"]) > 1:
        lines.append(f"P(a unit meets all limits) = {shown(spec['all']['next_unit'])}")
    return lines


def _effective_points(fleet: FleetFit) -> dict[str, float]:
    """unit -> effective number of its points behind the population (importance weights)."""
    posterior = fleet.population
    return dict(zip(posterior.units, map(float, posterior.point_ess), strict=True))


def fleet_result(fleet: FleetFit) -> dict:
    """The JSON document of ``bayescal fleet`` (module docstring)."""
    summary = fleet.summary
    posterior = fleet.population
    diagnostics = posterior.diagnostics.as_dict()
    diagnostics["criteria"] = {
        "max_rhat": MAX_RHAT,
        "min_ess_bulk": MIN_ESS,
        "acceptance_fraction": list(ACCEPTANCE_RANGE),
        "steps_per_autocorrelation_time": AUTOCORR_MULTIPLE,
        "min_effective_points_per_unit": MIN_POINT_ESS,
    }
    diagnostics["effective_points"] = _effective_points(fleet)
    diagnostics["effective_combined_draws"] = dict(
        zip(posterior.units, map(float, posterior.combined_ess), strict=True)
    )
    result = {
        "schema": "bayescal.fleet",
        "schema_version": 1,
        "bayescal_version": version("bayescal"),
        "manifest": fleet.source,
        "channel": fleet.channel,
        "unit": fleet.unit,
        "terms": list(fleet.terms),
        "seed": fleet.seed,
        "n_units": len(fleet.units),
        "n_recordings": len(fleet.recordings),
        "interval": 0.90,
        "passed": fleet.passed,
        "failures": list(fleet.failures),
        "population": summary["population"],
        "units": summary["units"],
        "outliers": summary["outliers"],
        "model": {
            "parameters": list(fleet.parameters),
            "description": "log p_u ~ Normal(mu_p, sigma_p) for each noise scale p (shared by "
            "a unit's runs); unit mean bias ~ Normal(mu_b, tau_unit); run bias ~ "
            "Normal(unit mean bias, tau_run); fitted from each recording's posterior draws "
            "reweighted by population prior over fitting prior (Hogg, Myers & Bovy 2010)",
            "prior": "mu flat; sigma_p half-Cauchy(0, "
            f"{LOG_SD_PRIOR_SCALE:g}); tau_unit, tau_run half-Cauchy(0, "
            f"{BIAS_SD_PRIOR_FACTOR:g} x the fleet's spread of turn-on biases)",
            "resolved": f"a noise scale enters when its posterior sd of ln is <= "
            f"{RESOLVED_LOG_SD:g} in at least half of the recordings",
            "points_per_unit": fleet.population.points_per_unit,
            "median_definition": "exp(mu_p): the population median",
            "log_sd_definition": "sigma_p: sd of the natural log across units",
            "bias_definition": "turn-on bias: the expected reading at the start of a run",
        },
        "diagnostics": diagnostics,
        "recordings": [_recording_entry(r) for r in fleet.recordings],
        "failed": [
            {
                "row": f.row,
                "source": f.source,
                "unit": f.unit,
                "run": f.run,
                "kind": f.kind,
                "message": f.message,
            }
            for f in fleet.failed
        ],
        "compute": fleet.compute,
        "notes": list(fleet.notes),
    }
    if summary["spec"] is not None:
        result["spec"] = {**summary["spec"], "verdict": spec_verdict(summary["spec"])}
    return result


def _entry(entry: dict) -> str:
    if entry.get("mean") is None:
        return f"n/a ({entry.get('note', '')})"
    return (
        f"{_number(entry['mean'])} [{_number(entry['q05'])}, {_number(entry['q95'])}] "
        f"{entry['unit']}"
    )


def _number(value) -> str:
    return "n/a" if value is None else f"{value:.4g}"


def _flagged(fleet: FleetFit) -> dict[str, list[str]]:
    """unit -> the parameters the population fitted without it does not predict."""
    units = fleet.summary["outliers"].get("units", {})
    return {unit: entry["flagged"] for unit, entry in units.items() if entry["flagged"]}


def fleet_text(fleet: FleetFit) -> str:
    """The table ``bayescal fleet`` prints.

    Over 80 lines: the table's blocks in the order printed (the population, the
    specification, the units, the outliers, the recordings left out, the checks)."""
    compute, summary = fleet.compute, fleet.summary
    lines = [
        f"bayescal fleet: {fleet.source}, channel {fleet.channel} [{fleet.unit}]",
        f"  {len(fleet.units)} units, {len(fleet.recordings)} recordings fitted "
        f"({len(fleet.failed)} left out); terms {', '.join(fleet.terms)}",
        f"  compute: {compute['tasks']} tasks on {compute['workers']} workers at "
        f"{compute['scheduler']} ({compute['cluster']}), {compute['wall_s']:.0f} s",
        "",
        "  population (posterior mean [90% interval])",
    ]
    population = summary["population"]
    for name in fleet.parameters:
        entry = population[name]
        lines.append(f"  {name:<6}median    {_entry(entry['median'])}")
        for label, shown in entry["display"].items():
            if shown["mean"] is not None:
                lines.append(
                    f"  {'':<6}          {_number(shown['mean'])} [{_number(shown['q05'])}, "
                    f"{_number(shown['q95'])}] {label}"
                )
        lines.append(f"  {'':<6}log-sd    {_entry(entry['log_sd'])}")
        lines.append(f"  {'':<6}next unit {_entry(entry['predictive'])}")
    bias = population["bias"]
    lines += [
        f"  bias  mean      {_entry(bias['mean'])}",
        f"        unit sd   {_entry(bias['unit_to_unit_sd'])}",
        f"        run sd    {_entry(bias['run_to_run_sd'])}",
        f"        next unit {_entry(bias['predictive'])}",
    ]
    spec = summary["spec"]
    if spec is not None:
        lines += ["", "  specification"] + [f"  {line}" for line in spec_verdict(spec)]
        lines += [f"    {limit['label']}: {limit['source']}" for limit in spec["limits"]]
    lines += ["", "  units (shrunk toward the population; own: the unit's runs alone)"]
    for unit, entry in summary["units"].items():
        parts = [
            f"{name} {_number(entry[name]['mean'])} (own {_number(entry[name]['own']['mean'])})"
            for name in (*fleet.parameters, "bias")
        ]
        lines.append(f"  {unit}: {len(entry['runs'])} run(s); " + "; ".join(parts))
    flagged = _flagged(fleet)
    if flagged:
        lines += ["", "  outliers (the population fitted without them does not predict them):"]
        lines += [f"  - {unit}: {', '.join(names)}" for unit, names in flagged.items()]
    if fleet.failed:
        lines += ["", "  recordings left out:"]
        lines += [f"  - {f.source} ({f.kind}): {f.message}" for f in fleet.failed]
    if fleet.passed:
        diagnostics = fleet.population.diagnostics
        lines += [
            "",
            f"  population posterior checks passed: {diagnostics.n_steps} steps x "
            f"{diagnostics.n_walkers} walkers, ESS >= "
            f"{min(diagnostics.ess_bulk.values()):.0f}, R-hat <= "
            f"{max(diagnostics.rhat.values()):.3f}, effective points per unit >= "
            f"{min(_effective_points(fleet).values()):.0f}",
        ]
    else:
        lines += ["", "  POPULATION CHECKS FAILED — do not use these numbers:"]
        lines += [f"    - {failure}" for failure in fleet.failures]
    if fleet.notes:
        lines += ["", "  notes:"] + [f"  - {note}" for note in fleet.notes]
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# The page


def units_figure(fleet: FleetFit, name: str):
    """Each unit's 90 % interval of ``name`` (shrunk, and its own in grey) beside the
    population's median (mean, for the bias) and the 90 % predictive range of the next
    unit."""
    summary = fleet.summary
    units = summary["units"]
    entry = summary["population"][name]
    unit = entry["median"]["unit"] if name != "bias" else fleet.unit
    figure, (axes,) = new_figure(7.2, 0.9 + 0.28 * len(units))
    positions = np.arange(len(units))[::-1]
    flagged = {u for u, names in _flagged(fleet).items() if name in names}
    for y, (unit_id, values) in zip(positions, units.items(), strict=True):
        own, shrunk = values[name]["own"], values[name]
        axes.plot([own["q05"], own["q95"]], [y + 0.15] * 2, color="0.6", lw=2)
        axes.plot(own["mean"], y + 0.15, "o", color="0.6", ms=4)
        colour = "#b00020" if unit_id in flagged else "#3182bd"
        axes.plot([shrunk["q05"], shrunk["q95"]], [y - 0.15] * 2, color=colour, lw=2.5)
        axes.plot(shrunk["mean"], y - 0.15, "o", color=colour, ms=5)
    centre = entry["median"] if name != "bias" else entry["mean"]
    axes.axvline(centre["mean"], color="k", lw=1)
    axes.axvspan(centre["q05"], centre["q95"], color="k", alpha=0.12, lw=0)
    predictive = entry["predictive"]
    if predictive.get("q05") is not None:
        for edge in (predictive["q05"], predictive["q95"]):
            axes.axvline(edge, color="k", ls="--", lw=0.8)
    if name != "bias":
        axes.set_xscale("log")
    axes.set_yticks(positions, list(units))
    axes.set_xlabel(f"{name} [{pretty_unit(unit)}]")
    axes.set_title(
        f"{_NAMES.get(name, 'turn-on bias (unit mean)')}: blue, shrunk 90 % interval; grey, "
        "the unit alone; band, population "
        + ("median" if name != "bias" else "mean")
        + "; dashed, next unit 90 %",
        fontsize=8,
    )
    return figure


def _population_table(fleet: FleetFit) -> str:
    population = fleet.summary["population"]
    rows = []
    for name in fleet.parameters:
        entry = population[name]
        display = "".join(
            f"<br><span class='note'>{num(shown['mean'])} [{num(shown['q05'])}, "
            f"{num(shown['q95'])}] {esc(pretty_unit(label))}</span>"
            for label, shown in entry["display"].items()
            if shown["mean"] is not None
        )
        rows.append(
            f"<tr><td>{esc(_NAMES[name])}</td><td class='num'>{_cell(entry['median'])}"
            f"{display}</td><td class='num'>{_cell(entry['log_sd'])}</td>"
            f"<td class='num'>{_cell(entry['predictive'])}</td></tr>"
        )
    bias = population["bias"]
    rows.append(
        f"<tr><td>turn-on bias</td><td class='num'>mean {_cell(bias['mean'])}</td>"
        f"<td class='num'>unit-to-unit sd {_cell(bias['unit_to_unit_sd'])}<br>run-to-run sd "
        f"{_cell(bias['run_to_run_sd'])}</td><td class='num'>{_cell(bias['predictive'])}</td></tr>"
    )
    return (
        "<table><thead><tr><th>parameter</th><th>population median (mean [5 %, 95 %])</th>"
        "<th>spread across units (sd of ln)</th><th>next unit (mean [5 %, 95 %])</th></tr>"
        "</thead><tbody>" + "".join(rows) + "</tbody></table>"
    )


def _cell(entry: dict) -> str:
    if entry.get("mean") is None:
        return f"n/a <span class='note'>({esc(entry.get('note', ''))})</span>"
    return interval(entry["mean"], entry["q05"], entry["q95"], entry["unit"])


def _spec_html(spec: dict) -> list[str]:
    parts = ["<h2>Specification</h2><ul>"]
    parts += [f"<li><b>{esc(line)}</b></li>" for line in spec_verdict(spec)]
    parts.append("</ul><p class='note'>Limits: ")
    parts.append(
        "; ".join(f"{esc(limit['label'])} ({esc(limit['source'])})" for limit in spec["limits"])
    )
    parts.append(f". All limits: {esc(spec['all']['definition'])}.</p>")
    failing = {unit: p for unit, p in spec["all"]["units"].items() if p < 0.5}
    if failing:
        parts.append(
            "<p class='bad'>Units more likely than not to miss the limits: "
            + ", ".join(f"{esc(u)} (P = {p:.2f})" for u, p in failing.items())
            + "</p>"
        )
    return parts


def fleet_page(fleet: FleetFit) -> str:
    """The self-contained HTML page of a fleet.

    Over 80 lines: the page's sections in order (the alarms, the population, the
    specification, the units, the checks and where the work ran)."""
    created = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    title = f"Fleet {fleet.source}: {fleet.channel}"
    summary = fleet.summary
    parts = [
        *page_start(title),
        f"<p class='note'>{len(fleet.units)} units, {len(fleet.recordings)} recordings, "
        f"unit {esc(fleet.unit)}, terms {esc(', '.join(fleet.terms))} — bayescal "
        f"{esc(version('bayescal'))}, {created}</p>",
    ]
    if not fleet.passed:
        parts.append(
            "<div class='alarm'><h2>HEALTH CHECK FAILED</h2><p>The population's posterior "
            "failed its checks; do not use these numbers:</p><ul>"
            + "".join(f"<li>{esc(failure)}</li>" for failure in fleet.failures)
            + "</ul></div>"
        )
    if fleet.failed:
        parts.append(
            "<div class='alarm'><h2>Recordings left out</h2><ul>"
            + "".join(
                f"<li><code>{esc(f.source)}</code> (unit {esc(f.unit)}, run "
                f"{esc(f.run)}, {esc(f.kind)}): {esc(f.message)}</li>"
                for f in fleet.failed
            )
            + "</ul></div>"
        )
    parts += ["<h2>Population</h2>", _population_table(fleet)]
    if summary["spec"] is not None:
        parts += _spec_html(summary["spec"])
    flagged = _flagged(fleet)
    parts.append("<h2>Units</h2>")
    outliers = summary["outliers"]
    if flagged:
        parts.append(
            "<p class='bad'>Outliers — units the population, fitted without them, does not "
            "predict (in red): "
            + "; ".join(f"{esc(u)} ({esc(', '.join(n))})" for u, n in flagged.items())
            + "</p>"
        )
    elif outliers.get("threshold") is not None:
        parts.append(
            "<p class='ok'>No outlier: the population predicts every unit (two-sided tail "
            f"probability above {num(outliers['threshold'], 2)} for each).</p>"
        )
    for name in (*fleet.parameters, "bias"):
        parts.append(
            embedded(units_figure(fleet, name), f"{name} of each unit beside the population")
        )
    parts.append("<h2>Posterior checks and compute</h2>")
    diagnostics = fleet.population.diagnostics
    status = "<span class='ok'>passed</span>" if fleet.passed else "<span class='bad'>FAILED</span>"
    parts.append(
        f"<p>Population posterior: {status}; {diagnostics.n_steps} steps × "
        f"{diagnostics.n_walkers} walkers, max R-hat {num(max(diagnostics.rhat.values()))}"
        f", min bulk ESS {num(min(diagnostics.ess_bulk.values()))}, acceptance "
        f"{num(diagnostics.acceptance_fraction, 3)}, effective points per unit ≥ "
        f"{num(min(_effective_points(fleet).values()), 3)}.</p>"
    )
    compute = fleet.compute
    parts.append(
        f"<p>{compute['tasks']} tasks on {compute['workers']} workers at "
        f"<code>{esc(compute['scheduler'])}</code> ({esc(compute['cluster'])}): "
        f"{num(compute['wall_s'], 3)} s, a task {num(compute['task_s']['mean'], 3)} s on "
        f"average, {num(compute['result_bytes']['mean'] / 1e3, 3)} kB shipped back each.</p>"
    )
    parts.append(
        "<table><thead><tr><th>row</th><th>recording</th><th>unit</th><th>run</th>"
        "<th>samples</th><th>checks</th></tr></thead><tbody>"
        + "".join(
            f"<tr><td>{r.row}</td><td><code>{esc(r.source)}</code></td>"
            f"<td>{esc(r.unit)}</td><td>{esc(r.run)}</td><td>{r.n_samples}</td>"
            f"<td class='num'>R-hat {num(r.checks['max_rhat'])}, ESS "
            f"{num(r.checks['min_ess_bulk'])}</td></tr>"
            for r in fleet.recordings
        )
        + "</tbody></table>"
    )
    if fleet.notes:
        parts.append(
            "<ul class='note'>" + "".join(f"<li>{esc(note)}</li>" for note in fleet.notes) + "</ul>"
        )
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"
