"""The scenes a reader of the six-bar thesis (seed 001) can build for Configurations 1-6.

Figure 1-17 (where each configuration's boom is anchored) did not survive the text; what did is
the family (Chapter 1: base J1-J7 = 0.1 m, bars I, II, V, VI = 0.3 m, III and IV = 0.05 m
forming a ternary link locked at the mid-node J4; "the boom's two anchor points: one at the
base and the other at either the joints or the mid-node between Link III and IV", Chapter 5),
the start pose (the Appendix C listing's th, the same for Configurations 1-6, Figure 4-1) and
Table 4-4's parameters (the listing's k = 40 N/rad, theta0 = 30/120/30 deg from either base
pin, boom 100 N pushing to 0.3 m; Configuration 6: two booms of 0.30 and 0.28 m).

A :class:`Hypothesis` picks the discrete unknowns: the six-bar with the ternary link
(mid-node J4, five moving joints) or the five-link chain with III + IV merged into one 0.1 m
bar (four moving joints); the boom's base anchor (either end or the middle of the base); the
joint(s) it pushes; which joints carry no spring; whether the boom is welded to bar III
(Configuration 5); and, for two booms, whether Part 1 keeps pushing every boom until boom 1
reaches its length (``push-on``) or each boom locks on reaching its own (``staged``, the
physical deployment).  :func:`run` computes it with the thesis's own increments (the port
``reduced_models.thesis.force_method``: same equilibrium matrix, mechanism modes, spring
stiffness and force fractions 0.005 / 0.5) and returns ``Lo_tot`` of Part 1 and Part 2,
which is what Tables 4-5 to 4-10 print.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from reduced_models.thesis.chain import Chain, rebuild
from reduced_models.thesis.force_method import (
    PART1_DELTA,
    PART2_DELTA,
    PART2_TOL,
    ForceMethodState,
    solve_increment,
)

START_DEG = 5.7392  # the listing's start: th = [a, 180-a, 180, 180, 180+a, -a] deg
BASE = 0.1  # base J1 (x = 0.1) to the last ground joint (x = 0), m
SIDE, TERN = 0.3, 0.05  # bars I, II, V, VI; III and IV, m
K_SPRING = 40.0  # N/rad, Table 4-4 (the listing's k)
REST_DEG = (30.0, 120.0, 30.0)  # theta0 from either base pin inwards (the listing's theta0)
FORCE = 100.0  # N
LENGTHS = (0.30, 0.28)  # deployed lengths of boom 1 and boom 2, m (Tables 4-2 to 4-4)
MAX_INCREMENTS = 4000  # Part 1 of Configuration 4 takes 310; a stuck hypothesis stops here


@dataclass(frozen=True)
class Hypothesis:
    """One reading of a lost figure (see the module docstring).

    ``six_bar``: III and IV separate (mid-node J4) rather than one 0.1 m bar; ``base``: the
    boom base anchor, ``"J1"`` (x = 0.1), ``"mid"`` (x = 0.05) or ``"end"`` (x = 0, the last
    chain joint); ``tips``: the joint each boom pushes (boom 1 first, lengths ``LENGTHS``);
    ``no_spring``: joints (besides J4 of the six-bar, which never has one) without a spring;
    ``part1``: ``"push-on"`` or ``"staged"`` (only differs with two booms); ``fixed_to_III``:
    boom 1 welded to bar III at its tip (its line turns with the bar).
    """

    six_bar: bool
    base: str
    tips: tuple[str, ...]
    no_spring: tuple[str, ...] = ()
    part1: str = "push-on"
    fixed_to_III: bool = False

    @property
    def nodes(self) -> tuple[str, ...]:
        """Chain joints from J1 (x = 0.1) counter-clockwise to the last ground joint."""
        return tuple(f"J{i + 1}" for i in range(7 if self.six_bar else 6))

    def label(self) -> str:
        """One line: topology, anchors, springs, staging."""
        top = "six-bar (J4 mid-node)" if self.six_bar else "five-link (III+IV one bar)"
        base = {"J1": "J1", "mid": "base middle", "end": self.nodes[-1]}[self.base]
        booms = ", ".join(f"{base}->{t} {L:.2f} m" for t, L in zip(self.tips, LENGTHS))
        parts = [top, f"boom {booms}"]
        if self.fixed_to_III:
            parts.append("welded to bar III")
        off = "+".join(self.no_spring)
        parts.append(f"no spring at {off}" if off else "all springs")
        if len(self.tips) > 1:
            parts.append(self.part1)
        return "; ".join(parts)


def start_pose(six_bar: bool) -> np.ndarray:
    """Joint positions (m) of the listing's start pose, chain order, shape (n + 1, 2)."""
    c, s = math.cos(math.radians(START_DEG)), math.sin(math.radians(START_DEG))
    j2 = (BASE + SIDE * c, SIDE * s)
    j3 = (j2[0] - SIDE * c, j2[1] + SIDE * s)
    mid = [(j3[0] - TERN, j3[1])] if six_bar else []
    j5 = (j3[0] - 2 * TERN, j3[1])
    return np.array([(BASE, 0.0), j2, j3, *mid, j5, (j5[0] - SIDE * c, j5[1] - SIDE * s), (0, 0)])


def springs(h: Hypothesis, pos: np.ndarray) -> tuple[tuple[int, int, float, float], ...]:
    """The port's spring tuples (bar_a, bar_b or -1, k, free angle rad): rotation = higher-
    numbered bar minus lower-numbered (the last ground joint: its bar, rest -theta0)."""
    th = np.degrees(np.arctan2(*np.diff(pos, axis=0)[:, ::-1].T))
    n = len(pos) - 1
    rest = [*REST_DEG, None, *REST_DEG[::-1]] if h.six_bar else [*REST_DEG, *REST_DEG[::-1]]
    out = []
    for j, r in enumerate(rest):
        if r is None or h.nodes[j] in h.no_spring:
            continue
        if j == 0:
            a, b, now = 0, -1, th[0]
        elif j == n:
            a, b, now, r = n - 1, -1, th[-1], -r
        else:  # relative angle wrapped to the branch of the rest angle (120 deg: 168.5 deg)
            a, b, now = j, j - 1, (th[j] - th[j - 1] - r + 180.0) % 360.0 + r - 180.0
        out.append((a, b, K_SPRING, math.radians(r - now)))
    return tuple(out)


@dataclass
class Booms:
    """The booms of a hypothesis: shared base xy (m), tip chain indices, deployed lengths (m)
    and which are locked (Part 1 ``staged``: on reaching their length; Part 2: all)."""

    base: np.ndarray
    tips: tuple[int, ...]
    lengths: tuple[float, ...]
    locked: list[bool] = field(default_factory=list)


def build(h: Hypothesis) -> tuple[Chain, np.ndarray, Booms]:
    """The port's chain (boom 1 in its boom fields), the start pose and the boom set."""
    pos = start_pose(h.six_bar)
    base = {"J1": pos[0], "mid": np.array([BASE / 2, 0.0]), "end": pos[-1]}[h.base]
    tips = tuple(h.nodes.index(t) for t in h.tips)
    chain = Chain(
        nodes=h.nodes,
        free=tuple(range(1, len(pos) - 1)),
        welds=((2, 3),) if h.six_bar else (),
        springs=springs(h, pos),
        base=(float(base[0]), float(base[1])),
        tip=tips[0],
        force=FORCE,
        length=LENGTHS[0],
    )
    return chain, pos, Booms(base, tips, LENGTHS[: len(tips)], [False] * len(tips))


def _angle_gradient(nf: int, row: dict, p: int | None, q: int, vec: np.ndarray) -> np.ndarray:
    """Gradient (rad/m) of the angle of ``vec`` = x_q - x_p over the free joint dofs."""
    g = np.zeros(2 * nf)
    n = np.array([-vec[1], vec[0]]) / (vec @ vec)
    for j, s in ((q, 1.0), (p, -1.0)):
        if j in row:
            g[row[j] : row[j] + 2] += s * n
    return g


def state(
    chain: Chain, pos: np.ndarray, lengths: np.ndarray, booms: Booms, h: Hypothesis
) -> ForceMethodState:
    """The port's increment matrices with the hypothesis's boom columns: one axial column per
    locked boom, and for a boom welded to bar III the column of their relative angle."""
    st = ForceMethodState(chain, pos, lengths, locked=False)
    nf = len(chain.free)
    row = {j: 2 * k for k, j in enumerate(chain.free)}
    cols, dirs = [st.A], []
    for tip, locked in zip(booms.tips, booms.locked):
        v = pos[tip] - booms.base
        dirs.append(v / np.hypot(*v))
        if locked:
            c = np.zeros(2 * nf)
            c[row[tip] : row[tip] + 2] = dirs[-1]
            cols.append(c[:, None])
    if h.fixed_to_III:
        tip = booms.tips[0]
        g = _angle_gradient(nf, row, None, tip, pos[tip] - booms.base)
        g -= _angle_gradient(nf, row, 2, 3, pos[3] - pos[2])
        cols.append(g[:, None])
    st.A = np.hstack(cols)
    U, S, _ = np.linalg.svd(st.A)
    st.rank = int(np.sum(S > max(st.A.shape) * np.finfo(float).eps * S[0]))
    st.M = U[:, st.rank :]
    st.R = st.R_rows.T @ st.M
    st.boom_dirs = dirs
    st.boom_lengths = [float(np.hypot(*(pos[t] - booms.base))) for t in booms.tips]
    return st


@dataclass
class Totals:
    """``Lo_tot`` of Part 1 and Part 2 (N, free joints' x, y in chain order), boom lengths at
    the end of Part 1 (m) and whether both parts finished."""

    part1: np.ndarray
    part2: np.ndarray | None
    boom_lengths: tuple[float, ...]
    done: bool


def _part(
    chain: Chain,
    pos: np.ndarray,
    lengths: np.ndarray,
    rel: np.ndarray,
    booms: Booms,
    h: Hypothesis,
    *,
    part2: bool,
    first_deg: float | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, bool]:
    """One part; returns (positions, Lo_tot, spring rotations, increments, done)."""
    total = np.zeros(2 * len(chain.free))
    zero_load = math.inf
    for it in range(MAX_INCREMENTS):
        st = state(chain, pos, lengths, booms, h)
        if part2 and zero_load < PART2_TOL:
            return pos, total, rel, it, True
        if not part2:
            reached = [L > Ld for L, Ld in zip(st.boom_lengths, booms.lengths)]
            if reached[0] if h.part1 == "push-on" else all(reached):
                return pos, total, rel, it, True
            if h.part1 == "staged" and reached != booms.locked:
                booms.locked = [a or b for a, b in zip(reached, booms.locked)]
                st = state(chain, pos, lengths, booms, h)
        load0 = st.spring_load(rel, chain)
        load = load0.copy()
        for k, (tip, locked) in enumerate(zip(booms.tips, booms.locked)):
            if not part2 and not locked:
                d = st.boom_dirs[k]
                if it == 0 and k == 0 and first_deg is not None:  # the listing's typed th(7)
                    a = math.radians(first_deg)
                    d = np.array([math.cos(a), math.sin(a)])
                i = 2 * chain.free.index(tip)
                load[i : i + 2] += FORCE * d
        app = (PART2_DELTA if part2 else PART1_DELTA) * load
        d, dr = solve_increment(st, app, None)
        total, rel = total + app, rel + dr
        if part2:
            zero_load = float(np.linalg.norm(st.M.T @ load0))
        pos = rebuild(pos, lengths)
        pos[1:-1] += d.reshape(-1, 2)
    return pos, total, rel, MAX_INCREMENTS, False


def run(h: Hypothesis, first_deg: float | None = None) -> Totals:
    """Part 1 then Part 2 of the thesis's increments for ``h``.

    ``first_deg``: direction (deg) of boom 1's push in the first increment, the listing's
    typed ``th(7)`` (None: the drawn boom's own direction).
    """
    chain, pos, booms = build(h)
    lengths = np.hypot(*np.diff(pos, axis=0).T)
    rel = np.zeros(len(chain.springs))
    pos, t1, rel, n1, ok = _part(
        chain, pos, lengths, rel, booms, h, part2=False, first_deg=first_deg
    )
    reached = tuple(float(np.hypot(*(pos[t] - booms.base))) for t in booms.tips)
    if not ok:
        return Totals(t1, None, reached, False)
    booms.locked = [True] * len(booms.tips)
    lengths = np.hypot(*np.diff(pos, axis=0).T)  # L_f: Part 2 uses the reached lengths
    _, t2, _, n2, ok = _part(chain, pos, lengths, rel, booms, h, part2=True, first_deg=None)
    return Totals(t1, t2, reached, ok)
