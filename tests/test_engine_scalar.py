"""``engine._ScalarPath`` (one bare float, arithmetic written in place) follows a path exactly
as the generic ``engine._Path`` does through ``floats.Scalar``: same states, iterations,
cuts, residuals and stability flags, bit for bit, on smooth ramps, a limit point (a
softening spring: load control stops there), scaled and damped unknowns and a path that needs
step cuts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from reduced_models.paths import engine


def _both(monkeypatch: pytest.MonkeyPatch, *args: object, **kw: object) -> tuple:
    fast = engine.minimize_path(*args, **kw)
    monkeypatch.setattr(engine, "_ScalarPath", engine._Path)
    slow = engine.minimize_path(*args, **kw)
    monkeypatch.undo()
    return fast, slow


def _same(a, b) -> None:  # noqa: ANN001
    assert (a.ok, a.reason) == (b.ok, b.reason)
    for f in ("factors", "states", "iterations", "cuts", "residuals"):
        assert np.array_equal(getattr(a, f), getattr(b, f)), f
    assert list(a.stable) == list(b.stable)


def _pendulum(x: float, lam: float) -> tuple[float, float]:
    """A PRB-1R-like pivot: K x + lam (sin x + 2 cos x), h its derivative."""
    return 3.0 * x + lam * (math.sin(x) + 2.0 * math.cos(x)), 3.0 + lam * (
        math.cos(x) - 2.0 * math.sin(x)
    )


def _softening(x: float, lam: float) -> tuple[float, float]:
    """x - x^3 / 3 = lam: a limit point at lam = 2/3 (x = 1)."""
    return x - x**3 / 3.0 - lam, 1.0 - x * x


@pytest.mark.parametrize(
    "kw",
    [
        {},
        {"scale": [2.0], "max_step": 0.1},
        {"xtol": 1e-12, "gtol": 1e-11},
        {"keep_branch": False},
    ],
)
def test_scalar_path_is_the_generic_path(monkeypatch: pytest.MonkeyPatch, kw: dict) -> None:
    factors = np.linspace(0.0, 10.0, 21)
    lg = lambda x, lam: math.sin(x) + 2.0 * math.cos(x)  # noqa: E731
    _same(*_both(monkeypatch, _pendulum, 0.0, factors, load_gradient=lg, **kw))
    _same(*_both(monkeypatch, _pendulum, 0.0, factors, **kw))


def test_scalar_path_stops_at_a_limit_point_as_the_generic_path(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    fast, slow = _both(
        monkeypatch, _softening, 0.0, np.linspace(0.0, 1.0, 11), load_gradient=lambda x, lam: -1.0
    )
    _same(fast, slow)
    assert not fast.ok and fast.factors[-1] == pytest.approx(0.6)
    assert fast.cuts.sum() == 0 and "limit point" in fast.reason
