"""The cost estimate reuses the runner's timing repeats as its first samples (issue 22): the
solves already timed are not made again, and ``k`` single-call times make one sample."""

from __future__ import annotations

import pytest

from reports.verdicts import cost


def _counting() -> tuple[list[int], object]:
    calls = [0]

    def call() -> None:
        calls[0] += 1

    return calls, call


def test_repeats_that_fill_the_budget_are_the_estimate_without_a_new_solve() -> None:
    calls, call = _counting()
    runs = [0.009, 0.011, 0.010, 0.012] * 3  # 0.126 CPU s >= BUDGET_S after MIN_SAMPLES
    est = cost.measure(call, first_cpu_s=0.01, runs_cpu_s=runs)  # cold: not a sample
    assert calls[0] == 0
    assert est.n == 12 and est.cpu_s == pytest.approx(0.0105, rel=1e-12)  # their median


def test_a_first_solve_of_20_ms_or_more_is_a_sample() -> None:
    calls, call = _counting()
    est = cost.measure(call, first_cpu_s=0.05, runs_cpu_s=[0.04, 0.06])  # 0.15 s >= BUDGET_S
    assert calls[0] == 0
    assert est.n == 3 and est.cpu_s == pytest.approx(0.05, rel=1e-12)
    assert est.noise_s == pytest.approx((0.06 - 0.04) / 2, rel=1e-12)  # range below 6 samples


def test_a_solve_of_the_budget_or_more_is_its_own_estimate() -> None:
    calls, call = _counting()
    est = cost.measure(call, first_cpu_s=cost.BUDGET_S)
    assert calls[0] == 0 and (est.cpu_s, est.noise_s, est.n) == (cost.BUDGET_S, 0.0, 1)


def test_k_single_calls_make_one_sample() -> None:
    # first solve 0.25 ms: k = 4 calls per 1 ms sample; 12 runs = 3 samples of their mean
    calls, call = _counting()
    runs = [1e-4, 3e-4, 2e-4, 2e-4] + [0.1] * 4 + [0.2] * 4 + [7e-4]  # the 13th: no group
    est = cost.measure(call, first_cpu_s=2.5e-4, runs_cpu_s=runs)
    assert est.n == 3 and calls[0] == 0  # (2e-4 + 0.1 + 0.2) * 4 CPU s >= BUDGET_S
    assert est.cpu_s == pytest.approx(0.1, rel=1e-12)
    assert est.noise_s == pytest.approx((0.2 - 2e-4) / 2, rel=1e-12)


def test_without_repeats_it_samples_the_call() -> None:
    calls, call = _counting()
    est = cost.measure(call, first_cpu_s=0.01)
    assert calls[0] > 0 and est.n >= cost.MIN_SAMPLES
