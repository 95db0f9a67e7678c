"""Discovery's honest "unexplained" (issue 33 item 2) on seeded simulations: a finding whose
log Bayes factor and ELPD gain disagree is not named, its mismatch is reported unexplained
with both numbers, and the run fails its checks (the command line's exit 1)."""

import numpy as np

import bayescal as bc
from bayescal.inference import _discovery_search
from bayescal.models.effects.output_filter import OutputFilter

WHITE_SD = 0.05  # deg/s per sample


def test_a_filter_whose_evidence_disagrees_with_its_predictions_is_not_named(monkeypatch):
    """White noise at 100 Hz, with the filter decision made to return a strong one-tap
    low-pass (coefficient 0.8) at log Bayes factor +50: the record has no filter, so the
    model with it predicts far worse (negative ELPD gain). Discovery must leave it out of
    the named effects and the model, report both numbers unexplained, and fail."""
    values = WHITE_SD * np.random.default_rng(1).standard_normal(2**15)
    forced = (OutputFilter(coefficient=0.8), 50.0, {"parameters": {}, "shapes": []})
    monkeypatch.setattr(_discovery_search, "_high_band_deficit", lambda checks, rate: True)
    monkeypatch.setattr(_discovery_search, "decide_output_filter", lambda context, base: forced)
    found = bc.discover(values, 100.0, unit="deg/s", posterior=False, seed=1)
    assert "output_filter" not in {effect.name for effect in found.effects}
    assert "output_filter" not in found.final_terms
    (entry,) = found.unexplained["disagreeing"]
    assert entry["name"] == "output_filter"
    assert entry["log_bayes_factor"] == 50.0
    assert entry["delta_elpd"] < 0
    assert "+50.0" in found.unexplained["explanation"]
    assert any("output_filter" in failure for failure in found.failures)
    assert not found.passed


def test_a_scale_factor_change_under_a_ramp_is_located_and_not_named():
    """A slow input ramp (15 sample sd over the record) through zero at 190 s, seen by a
    scale factor that grows by 10 % there: the slope kinks. 2^14 samples at 50 Hz (328 s).
    The ramp may be named; the kink is no catalogue effect's, so a slow term that absorbs it
    (a random walk, a warm-up) must lose to the drift the level scan locates, and the
    mismatch is reported unexplained as a drift within 3 % of the record (10 s) of 190 s."""
    rng = np.random.default_rng(3)
    n, rate = 2**14, 50.0
    t = np.arange(n) / rate
    ramp = 15 * WHITE_SD / t[-1]
    values = WHITE_SD * rng.standard_normal(n) + ramp * (t - 190.0) * (1 + 0.10 * (t >= 190.0))
    found = bc.discover(values, rate, unit="deg/s", posterior=False, seed=3)
    assert {effect.name for effect in found.effects} <= {"rate_ramp"}
    (scan,) = [m for m in found.unexplained["mismatches"] if m["check"] == "level_scan"]
    assert scan["shape"] == "drift"
    assert abs(scan["time_s"] - 190.0) <= 0.03 * t[-1]


def test_the_telegraph_simulator_switches_at_its_rates():
    """Over 10^6 s with rates 1/60 and 1/40 per s (mean dwells 60 s low, 40 s high) the
    mean dwells of the simulator are within 3 % of 60 s and 40 s (about 10^4 dwells each:
    a 1 % standard error)."""
    from bayescal.models.effects.random_telegraph import telegraph_switches

    switches = np.array(telegraph_switches(np.random.default_rng(0), 1e6, (1 / 60, 1 / 40)))
    dwells = np.diff(np.concatenate([[0.0], switches]))
    assert abs(dwells[0::2].mean() - 60.0) <= 0.03 * 60.0
    assert abs(dwells[1::2].mean() - 40.0) <= 0.03 * 40.0


def test_a_random_telegraph_is_found_by_its_switches_and_named():
    """A two-level telegraph of 0.5 sample sd switching at 60, 130, 210 and 260 s over 2^14
    samples at 50 Hz (328 s), on white noise: named ``random_telegraph`` alone, each switch
    within 2 s of a located one, the size within 20 % of the truth, and the switching rates
    reported with 90 % intervals in 1/s."""
    rng = np.random.default_rng(5)
    n, rate = 2**14, 50.0
    t = np.arange(n) / rate
    switches = np.array([60.0, 130.0, 210.0, 260.0])
    flips = np.searchsorted(switches, t, side="right") % 2
    values = WHITE_SD * rng.standard_normal(n) + 0.5 * WHITE_SD * flips
    found = bc.discover(values, rate, unit="deg/s", posterior=True, seed=5)
    assert [effect.name for effect in found.effects] == ["random_telegraph"]
    (effect,) = found.effects
    located = np.array(effect.parameters["switches"]["value"])
    assert all(np.min(np.abs(located - switch)) <= 2.0 for switch in switches)
    assert abs(effect.parameters["size"]["mean"] - 0.5 * WHITE_SD) <= 0.2 * 0.5 * WHITE_SD
    assert effect.parameters["rate_up"]["unit"] == "1/s"
    assert effect.parameters["rate_up"]["q05"] < effect.parameters["rate_up"]["q95"]
