"""The replay reports every snap it goes through in ``extras["critical_points"]`` (DESIGN.md,
"Critical points": kind "snap", factor, switched, "from" / "to"), counted as its message says,
and no snap on the smooth (if fast) natural path of an imperfect column.

The located factor is the static stability loss traced from the last stable settled state
(``factor_static``): the FE's on the replay's 32-element mesh, within 1e-3 of the converged
value (the replay states its mesh error, ~6e-4 L on these scenes).  The dynamic onset rides
alongside (``factor_dynamic``): the replay ramps the load at a finite rate, so its state
leaves the stable branch after a fold (it lags the ramp by ~ 2 zeta / omega_1 times its rate,
and a fold is passed slowly), and it has left it by the report factor at which it settles on
the far branch: ``static <= factor_dynamic <= to_factor``.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import cases
from fem_reference.replay import honesty
from fem_reference.replay.honesty import same_branch
from fem_reference.replay.model import Replay
from fem_reference.replay.run import ReplayOptions, replay_system
from reports.api import make_model
from tests.test_verify_replay import VonMisesTruss, truss_branch, truss_limit

HOSTILE = Path(__file__).parent / "fixtures"  # scenes of the outside review, kept


def snaps(sol) -> list[dict]:
    """The snaps of ``sol``, checked for the contract's form and the message's count."""
    points = sol.extras["critical_points"]
    assert all(p["kind"] == "snap" and p["switched"] is True for p in points)
    assert all({"factor", "from", "to"} <= set(p) for p in points)
    (count,) = re.findall(r"(\d+) jump\(s\)", sol.message)
    assert int(count) == len(points) == len(sol.extras["jumps"]), sol.message
    return points


def test_truss_snap_at_its_exact_limit_point():
    """Von Mises truss (exact statics): one snap, after the exact limit point and no later
    than the sample it settles at, from the near branch onto the exact far branch."""
    tr = VonMisesTruss()
    yl, lcr = truss_limit(tr)
    factors = [0.0, 0.5 * lcr, 0.9 * lcr, 1.1 * lcr, 1.3 * lcr]
    sol = replay_system(tr, factors, options=ReplayOptions(probe="none"))
    assert sol.ok, sol.message
    (p,) = snaps(sol)
    assert p["to_factor"] == factors[3]
    assert lcr <= p["factor"] <= p["to_factor"] * (1 + 1e-12)  # the ramp's factor: round-off
    # it left where the tangent stops being positive definite: the exact limit point's apex
    assert p["from"]["apex.y"] == pytest.approx(yl, abs=0.01 * tr.a)
    far = truss_branch(tr, p["to_factor"], -3.0 * tr.h, -yl)
    assert p["to"]["apex.y"] == pytest.approx(far, abs=1e-6 * tr.a)


def test_offcentre_bistable_snap_located_as_the_elastica():
    """The asymmetric bistable switch snaps between the report factors 0.15 and 0.2 (shuttle
    1 -> 22 mm), dissipating less than half the work done: reported, at the elastica's snap
    factor within the tolerance of the module docstring."""
    sc = cases.load(HOSTILE / "bistable-asym-m-n-pa.toml")
    sol = Replay(probe="none").solve(sc)
    assert sol.ok, sol.message
    (p,) = snaps(sol)
    el = make_model("elastica", sc).solve(sc)
    assert el.ok, el.message
    (lam,) = [q["factor"] for q in el.extras["critical_points"] if q["kind"] == "snap"]
    assert lam <= p["factor_dynamic"] <= p["to_factor"] == pytest.approx(0.2)
    assert p["factor"] == p["factor_static"] == pytest.approx(lam, rel=1e-3)
    to = next(s for s in sol.steps if s.factor == p["to_factor"])
    assert p["to"] == dict(to.outputs)
    assert p["from"]["sh.ux"] < 0.003 < 0.02 < p["to"]["sh.ux"]


def test_offcentre_switch_snap_at_its_fold():
    """The switch pushed off its centre (an imperfect bifurcation: a fold at the elastica's
    0.15737) snaps between the report factors 0.15 and 0.2; load control from the last stable
    state lands past the fold on its unstable side, and the fold is located on the path
    traced ahead of that landing (the eigenvalue's interpolation inside the load step put it
    at 0.1554)."""
    sol = Replay(probe="none").solve(cases.load(HOSTILE / "bistable-offload-m-n-pa.toml"))
    assert sol.ok, sol.message
    (p,) = snaps(sol)
    assert p["factor"] == pytest.approx(0.15737276, rel=1e-3)
    assert p["factor"] <= p["factor_dynamic"] <= p["to_factor"] == pytest.approx(0.2)


def test_symmetric_switch_snap_from_its_bifurcation():
    """DAS-2D Ex. 3 without its guide (catalog): the symmetric path loses stability at the
    bifurcation the case documents (factor 0.432073, fem-auto Richardson; elastica 0.43203).
    The perfectly symmetric replay is held at the first report factor past it on the unstable
    symmetric state, is displaced off that saddle and snaps there (a real switch, or the
    same scene in other coordinates, would leave it at a time set by round-off)."""
    sol = Replay(probe="none").solve(cases.load("das2d-ex3-bistable-switch-load"))
    assert sol.ok, sol.message
    (p,) = snaps(sol)
    assert p["factor"] == p["factor_static"] == pytest.approx(0.432073, rel=1e-3)
    assert p["to_factor"] == pytest.approx(0.45)  # the first report factor past it
    assert p["from"]["shuttle_top.ux"] < 3.0 and p["to"]["shuttle_top.ux"] > 18.0  # mm


@pytest.mark.parametrize(
    "scene",
    [HOSTILE / "col-6x-eps0-001-a10000.toml", "column-postbuckling"],
    ids=lambda s: Path(s).stem,
)
def test_imperfect_column_natural_path_has_no_snap(scene, monkeypatch):
    """An imperfect column past its Euler load moves far more in one report increment than
    the tangent predicts (and the lagging ramp bursts across the knee), but along one stable
    natural path: the static trace lands on the settled end, and no snap is reported (its
    exact postbuckling path has no limit point)."""
    verdicts = []

    def spy(*args):
        verdicts.append(same_branch(*args))
        return verdicts[-1]

    monkeypatch.setattr(honesty, "same_branch", spy)
    sol = Replay(probe="none").solve(cases.load(scene))
    assert sol.ok, sol.message
    assert snaps(sol) == []
    assert verdicts and all(v is True for v in verdicts)  # candidates, each on one branch
    moved = max(abs(s.outputs[k]) for s in sol.steps for k in ("tip.ux", "tip.uy"))
    assert moved > 0.1 * 1.0  # it did move a lot (both columns are 1 long)


def test_replay_repeats_itself_to_the_last_bit():
    """The same scene replayed twice in one process gives the same numbers, bit for bit: the
    replay's damping comes from ARPACK's two lowest modes (479 DOFs), whose random start made
    the located snap factor of this switch wander by 3e-7 from run to run."""
    sc = cases.load(HOSTILE / "bistable-asym-m-n-pa.toml")
    first, second = (Replay(probe="none").solve(sc) for _ in range(2))
    assert first.ok and second.ok, (first.message, second.message)
    assert [dict(s.outputs) for s in first.steps] == [dict(s.outputs) for s in second.steps]
    assert first.extras["critical_points"] == second.extras["critical_points"]
