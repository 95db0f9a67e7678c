"""A small seeded version of ``benchmarks/discovery_suite.py``: the detection limit by which
the suite judges its target (the log Bayes factor a recording can be expected to hold for a
hidden effect, computed from the truth) against the evidence discovery observes."""

import math

import numpy as np
import pytest
from _benchmarks import load_benchmark

import bayescal as bc
from bayescal.inference._discovery_search import DECISIVE_LOG_BAYES_FACTOR

suite = load_benchmark("discovery_suite")


@pytest.mark.parametrize(
    ("hidden", "seed"),
    [
        (("thermal_bias",), 22),  # far above the limit
        (("thermal_bias", "rate_random_walk"), 27),  # below it: the suite's seed 0, #27
    ],
)
def test_expected_evidence_for_a_thermal_bias_matches_what_discovery_observes(hidden, seed):
    """The thermal term's log Bayes factor is a linear signal's matched-filter statistic: with
    the costs added back, a noncentral chi-square whose sd is sqrt(2 x its mean). The observed
    one (accepted, or the best rejected candidate) must lie within 3 sd of the expectation,
    and the term is named exactly when the expectation clears the decisive limit."""
    values, rate, temperature, truth = suite.simulate(hidden, np.random.default_rng(seed), seed)
    expected = suite.expected_log_bayes_factors(truth, rate, values.size, temperature)
    found = bc.discover(values, rate, temperature=temperature, unit="deg/s", posterior=False)
    observed = {effect.name: effect.evidence["log_bayes_factor"] for effect in found.effects}
    undecided = found.result.undecided
    observed |= {undecided.name: undecided.log_bayes_factor} if undecided else {}
    gross = expected["thermal_bias"] + 0.5 * math.log(values.size / 2)
    assert abs(observed["thermal_bias"] - expected["thermal_bias"]) < 3 * math.sqrt(2 * gross)
    named = "thermal_bias" in [effect.name for effect in found.effects]
    assert named == (expected["thermal_bias"] > DECISIVE_LOG_BAYES_FACTOR)


def test_verdict_bounds_are_the_exact_binomial_ones():
    # With no failures (or no successes) the Clopper-Pearson bound has a closed form.
    lower, upper = suite._binomial_bounds(158, 158, 0.95)
    assert lower == pytest.approx(0.05 ** (1 / 158)) and upper == 1.0
    lower, upper = suite._binomial_bounds(0, 48, 0.95)
    assert lower == 0.0 and upper == pytest.approx(1 - 0.05 ** (1 / 48))
    results = [{"found": [], "hidden": [], "expected": {}, "covered": {}}] * 10
    results += [
        {
            "found": ["sinusoid"],
            "hidden": ["sinusoid"],
            "expected": {"sinusoid": 50.0},
            "covered": {"sinusoid.amplitude": k % 10 != 0},
        }
        for k in range(100)
    ]
    lines = "\n".join(suite.target_verdict(results))
    assert "named in >= 95 %: 100/100, lower bound 0.970" in lines and "shown" in lines
    assert "0/10 clean controls alarmed" in lines and ": met" in lines
    assert "90 % intervals cover: 90/100" in lines and "at the stated rate" in lines
