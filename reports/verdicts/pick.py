"""The one rule that names a model: ``flexbench recommend``, the report's front page and the
teaching page all call ``choose``.

Given the candidates of one case (model, qualifies?, judged error, cost estimate with its
noise, a-priori unknowns), the pick is the cheapest qualifying model, where costs that cannot be
told apart are a tie broken by a fixed order:

1. *cost*: ``c0`` is the lowest cost of a qualifying model.  A qualifying model with cost
   ``c`` is tied with it when ``c - c0 <= max(noise + noise0, TIE * c0)``: within the two
   estimates' measured noise (``reports.verdicts.cost``: half-widths of their 95 % intervals), or
   within ``TIE`` of ``c0``: the spread of one model's estimate between processes on a shared
   machine (cache state, frequency, neighbours' memory traffic), which no repetition inside
   one process shows.  Measured on the project's 2-core machine under load: five fresh
   estimates of prb-2r on cantilever-inclined-tension ranged 0.554-0.639 ms (+-7 %), of
   prb-3r 0.61-0.67 ms, while each run's own noise said +-3-6 %.  A 20 % band keeps two such
   models tied in every run; a real 20 % saving on a millisecond solve is not worth a bigger
   model.
2. *fewer unknowns*: among the tied, the model with the fewest a-priori unknowns
   (``unknowns``): the smaller model does the same job.
3. *name*: then the alphabetically first name.

``decided_by`` says which rule settled it: ``"only qualifying"``, ``"cost"``,
``"tie: fewer unknowns"`` or ``"tie: name"`` (None when nothing qualifies).
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Sequence

from cases.schema import Member, Scene

TIE = 0.20  # least relative cost difference that decides (see module docstring)
# exact where they run and are the case's reference: beam theory for single beams, rigid-body
# kinematics with springs (kinetostatic declines any compliant member): candidates with error 0
EXACT = ("elastica", "kinetostatic")
# never candidates: the BVP twin of the elastica (a timing baseline) and the dynamic replay
EXCLUDED = ("elastica-bvp", "replay")


@dataclasses.dataclass(frozen=True)
class Option:
    """One candidate: cost and noise in CPU s (None: not measured), unknowns (None: not known
    a priori, ranked after every known count), judged error (shown, not ranked)."""

    model: str
    qualifies: bool
    cost_s: float | None
    noise_s: float = 0.0
    unknowns: int | None = None
    error: float | None = None


@dataclasses.dataclass(frozen=True)
class Pick:
    """The chosen model (None: none qualifies), the rule that decided, the models tied with
    the cheapest (pick included, cheapest first) and the band that made the tie (CPU s)."""

    model: str | None
    decided_by: str | None
    tied: tuple[str, ...] = ()
    band_s: float = 0.0

    def explain(self, options: Sequence[Option]) -> str:
        """The deciding rule in words, with the numbers it compared."""
        by = {o.model: o for o in options}
        if self.model is None:
            return "no model qualifies"
        p = by[self.model]
        if self.decided_by == "only qualifying":
            return "decided by: the only qualifying model"
        if self.decided_by == "cost":
            ok = sorted((o for o in options if o.qualifies), key=by_cost)
            nxt = next(o for o in ok if o.model != self.model)
            return (
                f"decided by cost: {_ms(p)} against {nxt.model} {_ms(nxt)}, apart by more "
                f"than the noise and {TIE:.0%}"
            )
        others = ", ".join(f"{m} {_ms(by[m])}" for m in self.tied if m != self.model)
        rule = "fewer unknowns" if self.decided_by == "tie: fewer unknowns" else "then name"
        counts = ", ".join(f"{m} {_count(by[m].unknowns)}" for m in self.tied)
        return (
            f"decided by the tie-break ({rule}): {self.model} {_ms(p)} tied with {others} "
            f"(within {self.band_s * 1e3:.3g} ms: noise or {TIE:.0%}); unknowns: {counts}"
        )


def _ms(o: Option) -> str:
    if o.cost_s is None:
        return "(cost not measured)"
    return f"{o.cost_s * 1e3:.3g} ± {o.noise_s * 1e3:.2g} ms"


def _count(n: int | None) -> str:
    return "?" if n is None else str(n)


def _cost(o: Option) -> float:
    return math.inf if o.cost_s is None else o.cost_s


def by_cost(o: Option) -> tuple:
    """Sort key: cost, then the tie-break order (unmeasured costs last)."""
    return (_cost(o), _order(o))


def _order(o: Option) -> tuple:
    """The fixed tie-break order: fewer unknowns, then name."""
    return (math.inf if o.unknowns is None else o.unknowns, o.model)


def band(cheapest: Option, other_noise_s: float = 0.0) -> float:
    """Cost difference (s) within which another model ties with ``cheapest``."""
    c0 = _cost(cheapest)
    return max(cheapest.noise_s + other_noise_s, TIE * c0) if math.isfinite(c0) else 0.0


def choose(options: Sequence[Option]) -> Pick:
    """The pick among ``options`` (module docstring); independent of their order."""
    ok = sorted((o for o in options if o.qualifies), key=by_cost)
    if not ok:
        return Pick(None, None)
    if len(ok) == 1:
        return Pick(ok[0].model, "only qualifying", (ok[0].model,))
    c0 = ok[0]
    tied = [o for o in ok if _cost(o) - _cost(c0) <= band(c0, o.noise_s) or _cost(o) == _cost(c0)]
    width = max(band(c0, o.noise_s) for o in tied)
    names = tuple(o.model for o in tied)
    if len(tied) == 1:
        return Pick(c0.model, "cost", names, width)
    first, second = sorted(tied, key=_order)[:2]
    rule = "tie: name" if _order(first)[0] == _order(second)[0] else "tie: fewer unknowns"
    return Pick(first.model, rule, names, width)


def cannot_tie(bound_s: float, cheapest: Option) -> bool:
    """True when a model costing at least ``bound_s`` cannot tie with ``cheapest`` (the early
    exit of ``recommend``'s ladders; its own noise taken as ``TIE`` of its cost at most)."""
    return bound_s - _cost(cheapest) > band(cheapest, TIE * bound_s)


# -- a-priori unknowns -------------------------------------------------------------------------
def unknowns(name: str, scene: Scene) -> int | None:
    """Unknowns a model solves for on ``scene``, counted from its definition (None: not known).

    Per flexible member: PRB models one per revolute joint of their PRB matrix (prb-short and
    prb-1r 1, prb-2r 2, prb-3r 3, prb-fsm-N N, prb-custom its matrix rows) plus one per
    prismatic spring where the member has an axial stiffness (prb-2rpr: 3 + 2); the chained
    segment models (linear-N, cbcm-N; bcm = cbcm-1) 3 per segment (node x, y, angle; the axial
    multiplier of their mixed form is not a degree of freedom); fem-N 3 per node, 3 N; the
    elastica 2 shooting unknowns on a cantilever and, in a mechanism, N + 3 = 27 collocation
    unknowns per member; ``mixed`` the sum of its members' models.  Rigid-body coordinates of a
    mechanism's nodes are shared by every assembler model and not counted (``kinetostatic``:
    0).  A ``family-auto`` model solves N0, 2 N0 and 4 N0 first: the sum of those.
    """
    from reduced_models.beam.single_beam import cantilever_of
    from reduced_models.mechanism.model import member_spec

    flex = [m for m in scene.members if m.kind == "flexible"]
    if name == "kinetostatic":
        return 0
    if name == "mixed":
        per = [_member_unknowns(member_spec(m.model or "", m.model_options), m) for m in flex]
        return None if None in per or not per else sum(per)
    if name.endswith("-auto"):
        from reports import api

        start = int(getattr(api.make_model(name, scene), "start", 1))
        parts = [unknowns(f"{name[:-5]}-{start * k}", scene) for k in (1, 2, 4)]
        return None if None in parts else sum(parts)
    fem = re.fullmatch(r"fem-(\d+)", name)
    if fem:
        return 3 * int(fem[1]) * max(len(flex), 1)
    if name == "elastica" and len(scene.members) == 1 and not isinstance(cantilever_of(scene), str):
        return 2
    per = [_member_unknowns(member_spec(name, scene.model_options(name)), m) for m in flex]
    return None if None in per or not per else sum(per)


def _member_unknowns(spec: tuple | str, member: Member) -> int | None:
    import numpy as np

    from reduced_models.mechanism import elastica_member

    if isinstance(spec, str):
        return None
    if spec[0] == "prb":
        joints = int(np.isfinite(spec[1][:, 0]).sum())
        stretch = int(np.isfinite(spec[1][:, 1]).sum()) if math.isfinite(member.EA) else 0
        return joints + stretch
    if spec[0] == "chain":
        return 3 * int(spec[2])
    if spec[0] == "elastica":
        return elastica_member.N + 3
    return None
