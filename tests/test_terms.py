"""The registry of noise terms: every term declared once and whole, every parameter's one range
kept wherever an interval is reported, and the Gauss-Markov term recovering its truth."""

import math

import pytest

import bayescal as bc
from bayescal.models._terms import (
    NOISE_TERMS,
    PARAMETERS,
    TERM_ALIASES,
    display_values,
    parameter_unit,
)
from bayescal.models.effects._parameter import Context
from bayescal.models.effects.output_filter import OutputFilter

RATE = 100.0
CONTEXT = Context(RATE, 600.0, 1e-6)


def test_every_term_is_declared_once_and_whole():
    names = [term.name for term in NOISE_TERMS]
    assert len(set(names)) == len(names)
    aliases = [alias for term in NOISE_TERMS for alias in (term.name, *term.aliases)]
    assert len(set(aliases)) == len(aliases), "an alias names two terms"
    assert all(TERM_ALIASES[alias] in names for alias in aliases)
    parameters = [p.name for term in NOISE_TERMS for p in term.parameters]
    assert len(set(parameters)) == len(parameters)
    streams = [stream for term in NOISE_TERMS for stream in term.streams]
    assert len(set(streams)) == len(streams), "two terms draw on one PRNG stream"
    for term in NOISE_TERMS:
        assert term.parameters and term.explanation and term.__doc__, term.name
        assert term.parameter == term.parameters[0].name


@pytest.mark.parametrize("channel_unit", ["deg/s", "rad/s", "m/s^2", "g", "LSB"])
def test_every_parameter_has_a_unit_and_its_display_units_convert(channel_unit):
    """A parameter's unit derives from the channel's (IEEE Std 952); its conventional display
    units are of the same dimension (the conversion would refuse them otherwise), and an
    opaque unit gets none."""
    for name in PARAMETERS:
        assert parameter_unit(name, channel_unit)
        shown = display_values(name, 1.0, channel_unit)
        if channel_unit == "LSB":
            assert shown == {}
        assert all(math.isfinite(value) and value > 0 for value in shown.values()), name
    assert display_values("N", 0.01, "deg/s") == pytest.approx({"deg/sqrt(h)": 0.6})
    assert parameter_unit("gm_tau", "deg/s") == "s"


def test_a_terms_classical_reading_is_in_its_parameters_unit():
    """A term read off the Allan deviation (IEEE Std 952 Annex C) is read in the unit of the
    parameter it reads, and shown in the same datasheet units: the report labels a classical
    reading from the reading's own line, a posterior from the registry."""
    read = [term for term in NOISE_TERMS if term.reading is not None]
    assert {term.parameter for term in read} == {"Q", "N", "B", "K"}
    for term in read:
        parameter = term.parameters[0]
        assert parameter.datasheet
        assert term.reading.time_power == parameter.time_power, term.name


@pytest.mark.parametrize("name", list(PARAMETERS))
def test_every_interval_lies_inside_its_parameters_range(name):
    """However wide the Laplace sd, near either end of the range, the interval stays inside it
    (taken in the parameter's coordinate); so does every value of the coordinate. The
    one-tap filter's F lies in (0, 1) here, in discovery and in the thermal fit alike (a
    discovery once reported F in [0.351, 1.192])."""
    parameter = PARAMETERS[name]
    low, high = parameter.bounds(CONTEXT)
    for x in (-40.0, -3.0, 0.0, 3.0, 40.0):
        value = float(parameter.natural(x, CONTEXT))
        assert low <= value <= high
        for sd in (1e-6, 1.0, 1e6):
            scale = abs(value) if value != 0 else 1.0
            if not low < value < high:
                continue
            a, b = parameter.interval(value, sd * scale, CONTEXT, 1.645)
            assert low <= a <= value <= b <= high, (name, value, sd, a, b)
    assert PARAMETERS["F"].bounds(CONTEXT) == (0.0, 1.0)


@pytest.mark.parametrize(
    "terms, truth",
    [
        (
            "all",
            dict(N=0.004, F=0.4, B=4e-4, K=1e-4, Q=1e-5, R=1e-6, gm_sigma=1e-3, gm_tau=20.0),
        ),
        (
            ("white", "biquad_filter"),
            dict(
                N=0.004, **OutputFilter(shape="biquad", poles=(-0.6, 0.3), zeros=(0.7, 0.5)).values
            ),
        ),
        (
            ("white", "butterworth_filter"),
            dict(N=0.004, filter_cutoff=20.0, filter_order=3.0, filter_warping=0.5),
        ),
        (("white", "decimation_filter"), dict(N=0.004, filter_length=4.0, filter_stages=2.0)),
    ],
)
def test_a_fit_reports_every_interval_inside_its_range(terms, truth):
    """Fitted with every term (and each low-pass shape), each parameter's posterior mean,
    interval and MAP lie in its range."""
    values = bc.NoiseModel(RATE, 0.2, **truth).simulate(2**13, seed=4)
    fit = bc.fit_noise(values, RATE, terms=terms, seed=1, sampler=bc.Sampler(max_steps=3000))
    context = fit.fit.problem.context
    for name, summary in fit.summary.items():
        if name == "bias":
            continue
        low, high = PARAMETERS[name].bounds(context)
        for key in ("q05", "mean", "map", "q95"):
            assert low <= summary[key] <= high, (name, key, summary[key], low, high)


def test_the_gauss_markov_term_recovers_its_truth():
    """White noise and a first-order Gauss-Markov bias (sigma 3 mdeg/s, tau_c 20 s) over 11
    minutes at 100 Hz: the term's sigma and correlation time each lie in their 90 %
    intervals, and the posterior passed its checks (seeded; the coverage over many records
    is benchmarks/gauss_markov_coverage.py)."""
    truth = {"N": 0.005, "gm_sigma": 0.003, "gm_tau": 20.0}
    values = bc.NoiseModel(RATE, 0.1, **truth).simulate(2**16, seed=1)
    fit = bc.fit_noise(values, RATE, terms=("white", "gauss_markov"), seed=1, unit="deg/s")
    assert fit.passed, fit.failures
    for name, true in truth.items():
        summary = fit.summary[name]
        assert summary["q05"] < true < summary["q95"], (name, summary)
    assert fit.summary["gm_sigma"]["unit"] == "deg/s"
    assert fit.summary["gm_tau"]["unit"] == "s"


def test_the_command_line_lists_the_registry(run_cli):
    """`bayescal terms` lists every registered term with its other names and each
    parameter's unit for the channel's unit it is given."""
    code, out, _ = run_cli("terms", "--unit", "m/s^2")
    assert code == 0
    for term in NOISE_TERMS:
        assert term.name in out
        for parameter in term.parameters:
            assert f"{parameter.name} " in out
    assert "m/s^2/sqrt(Hz)" in out and "rrw" in out
