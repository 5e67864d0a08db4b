"""Paired comparisons and restart summaries: checked against answers known without the
module (a binomial by hand, a known mean, the interval's coverage over many draws)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mfcontrol.errors import ConfigError
from mfcontrol.experiments.statistics import MIN_PAIRS, paired, restarts

N = 30


def _draws(mu: float, repetitions: int, n: int = N, sigma: float = 1.0):
    """Paired scores whose differences a - b are N(mu, sigma), one seed a repetition."""
    for i in range(repetitions):
        rng = np.random.default_rng(1000 + i)
        b = rng.uniform(5.0, 10.0, n)
        yield b + rng.normal(mu, sigma, n), b


@pytest.mark.parametrize(("mu", "verdict"), [(-1.0, "A better"), (1.0, "B better")])
def test_a_clear_difference_is_found_and_its_interval_holds_the_true_mean(mu, verdict):
    # an effect of one standard deviation over 30 seeds: a t-test's power is above 0.999,
    # so every repetition must find it; the interval must hold mu about 92 % of the time
    # (the bootstrap's coverage at n = 30, measured): at least 15 of 20 (binomial
    # probability of fewer about 2 %)
    found = [paired(a, b, n_resamples=2000) for a, b in _draws(mu, 20)]
    assert [c.verdict for c in found] == [verdict] * 20
    held = sum(c.low <= mu <= c.high for c in found)
    assert held >= 15, held
    assert all(c.interval_method == "BCa" for c in found)


def test_no_difference_is_found_about_as_often_as_the_confidence_says(record_property):
    # mu = 0: the verdict is "no significant difference" exactly when the interval holds
    # the true mean; 400 repetitions of a ~0.92 coverage (sd 0.014) lie in 0.88 to 0.98,
    # and a broken interval (too narrow, or always wide) falls outside
    found = [paired(a, b, n_resamples=2000) for a, b in _draws(0.0, 400)]
    none = sum(c.verdict == "no significant difference" for c in found)
    record_property("counts", f"interval held 0 in {none} of 400")
    assert 0.88 * 400 <= none <= 0.98 * 400, none
    # and the errors split both ways
    assert sum(c.verdict == "A better" for c in found) >= 3
    assert sum(c.verdict == "B better" for c in found) >= 3


def test_the_interval_is_deterministic_with_its_seed_and_moves_with_another():
    a, b = next(_draws(0.3, 1))
    assert paired(a, b, seed=4) == paired(a, b, seed=4)
    assert paired(a, b, seed=4).low != paired(a, b, seed=5).low


def test_the_sign_test_is_the_binomial_of_the_wins_with_ties_dropped():
    # 12 seeds: A lower on 8, B on 2, 2 ties -> 8 successes of 10 against a fair coin;
    # two-sided p = 2 * P(X >= 8) = 2 * (C(10,8) + C(10,9) + C(10,10)) / 2^10 = 112/1024
    d = np.array([-1, -2, -3, -4, -5, -6, -7, -8, 1, 2, 0, 0], float)
    c = paired(10 + d, np.full(12, 10.0))
    assert (c.wins_a, c.wins_b, c.ties) == (8, 2, 2)
    assert c.sign_p == pytest.approx((45 + 10 + 1) * 2 / 1024, rel=1e-12)


def test_the_wilcoxon_p_value_of_all_positive_differences_by_hand():
    # 10 distinct positive differences: the signed-rank sum of the negatives is 0, which
    # one sign pattern of 2^10 gives; two-sided p = 2 / 1024
    a = np.arange(1.0, 11.0) + 20
    c = paired(a, np.full(10, 20.0))
    assert c.wilcoxon_p == pytest.approx(2 / 1024, rel=1e-12)
    assert c.sign_p == pytest.approx(2 / 1024, rel=1e-12)
    # one negative difference of rank 1 (the smallest |d|): W = 1, which two of 2^10
    # patterns reach at most (W = 0 and W = 1): p = 2 * 2 / 1024
    d = np.arange(1.0, 11.0)
    d[0] = -1.0
    c = paired(20 + d, np.full(10, 20.0))
    assert c.wilcoxon_p == pytest.approx(4 / 1024, rel=1e-12)


def test_zero_differences_give_no_evidence():
    c = paired(np.full(12, 3.0), np.full(12, 3.0))
    assert (c.low, c.high, c.interval_method) == (0.0, 0.0, "constant")
    assert (c.wilcoxon_p, c.sign_p, c.ties) == (1.0, 1.0, 12)
    assert c.verdict == "no significant difference"
    assert "No significant difference" in c.sentence()


@pytest.mark.parametrize("shift", [-0.375, 2.0**-30, 2.0])
def test_a_constant_shift_is_its_own_interval(shift):
    # shifts exact in binary on whole-number scores: every difference is the shift itself
    b = np.arange(1.0, 16.0)
    c = paired(b + shift, b)
    assert (c.low, c.high, c.mean_difference) == (shift, shift, shift)
    assert c.interval_method == "constant"
    assert c.verdict == ("A better" if shift < 0 else "B better")
    assert (c.wins_a, c.wins_b) == ((15, 0) if shift < 0 else (0, 15))


def test_swapping_a_and_b_mirrors_every_number():
    for a, b in [*_draws(-0.4, 2), *_draws(0.05, 2)]:
        ab, ba = paired(a, b), paired(b, a)
        assert ba.mean_a == ab.mean_b and ba.mean_b == ab.mean_a
        assert ba.mean_difference == pytest.approx(-ab.mean_difference, rel=1e-12)
        assert (ba.low, ba.high) == pytest.approx((-ab.high, -ab.low), rel=1e-9)
        assert (ba.wins_a, ba.wins_b, ba.ties) == (ab.wins_b, ab.wins_a, ab.ties)
        assert ba.wilcoxon_p == pytest.approx(ab.wilcoxon_p, rel=1e-12)
        assert ba.sign_p == pytest.approx(ab.sign_p, rel=1e-12)
        mirrored = {"A better": "B better", "B better": "A better"}
        assert ba.verdict == mirrored.get(ab.verdict, ab.verdict)
        if ab.verdict != "no significant difference":  # the same winner, the same words
            assert ab.sentence("X", "Y", "P") == ba.sentence("Y", "X", "P")


def test_the_sentence_says_who_beats_whom_with_the_winners_numbers():
    a, b = next(_draws(1.0, 1))  # B lower
    c = paired(a, b)
    text = c.sentence("i-PI", "PID", "bench-lag3")
    assert text.startswith("PID beats i-PI on bench-lag3: mean score ")
    # the difference is the winner's minus the loser's: negative, as its interval
    assert f"difference -{abs(c.mean_difference):#.3g}" in text
    assert f"PID lower on {c.wins_b} of 30 seeds" in text


scores = st.lists(st.floats(0.0, 10.0, allow_nan=False, allow_infinity=False),
                  min_size=MIN_PAIRS, max_size=14)


@settings(max_examples=60, deadline=None)
@given(scores, st.data())
def test_the_sentence_never_names_a_winner_when_the_interval_holds_zero(a, data):
    b = data.draw(st.lists(st.floats(0.0, 10.0, allow_nan=False, allow_infinity=False),
                           min_size=len(a), max_size=len(a)))
    c = paired(a, b, n_resamples=1000)
    text = c.sentence("X", "Y", "P")
    assert c.low <= c.high
    if c.low <= 0 <= c.high:
        assert c.verdict == "no significant difference"
        assert "beats" not in text and text.startswith("No significant difference")
    else:
        assert "beats" in text
        assert (c.high < 0) == text.startswith("X beats Y")


@pytest.mark.parametrize(("args", "kwargs", "named"), [
    (([1.0] * 9, [2.0] * 9), {}, "a = "),
    (([1.0] * 10, [2.0] * 11), {}, "b = "),
    (([1.0] * 10, [2.0] * 9 + [math.inf]), {}, "b[9] = inf"),
    (([1.0] * 3 + [math.nan] + [1.0] * 6, [2.0] * 10), {}, "a[3] = nan"),
    ((["1"] * 10, [2.0] * 10), {}, "a = "),
    ((np.ones((2, 10)), np.ones((2, 10))), {}, "a = "),
    (([1.0] * 10, [2.0] * 10), {"confidence": 95}, "confidence = 95"),
    (([1.0] * 10, [2.0] * 10), {"n_resamples": 100}, "n_resamples = 100"),
    (([1.0] * 10, [2.0] * 10), {"seed": 0.5}, "seed = 0.5"),
    (([1e308] * 10, [-1e308] * 10), {}, "b[0] = "),
])
def test_bad_input_is_refused_in_one_line_naming_the_argument(args, kwargs, named):
    with pytest.raises(ValueError, match="^" + named.replace("[", r"\[").replace("]", r"\]")) \
            as err:
        paired(*args, **kwargs)
    assert isinstance(err.value, ConfigError) and "\n" not in str(err.value)


def test_too_few_seeds_are_refused_saying_why():
    with pytest.raises(ValueError, match="at least 10 scores, not 5: below that"):
        paired([1.0] * 5, [2.0] * 5)


def test_restarts_summarise_the_spread():
    r = restarts([4.0, 2.0, 3.0, 2.0, 6.0])
    assert (r.n, r.best, r.worst, r.median, r.best_index) == (5, 2.0, 6.0, 3.0, 1)
    assert (r.spread, r.relative_spread) == (4.0, 2.0)
    assert restarts([0.0, 0.0]).relative_spread == 0.0
    assert restarts([0.0, 1.0]).relative_spread == math.inf


@pytest.mark.parametrize(("scores", "named"), [
    ([1.0], "scores = "), ([1.0, math.inf, 2.0], r"scores\[1\] = inf"),
    ([[1.0, 2.0]], "scores = ")])
def test_restarts_refuse_what_paired_refuses(scores, named):
    with pytest.raises(ValueError, match="^" + named):
        restarts(scores)
