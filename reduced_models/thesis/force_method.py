"""``thesis-force-method``: the six-bar thesis's incremental force method (seed 001, Appendix C).

A faithful port of the MATLAB listing for Configuration 4, written for any scene of the same
family: a serial chain of rigid bars from one pinned ground node to another (read from the
graph: any member order, direction or node names; run from the end the thesis numbers first:
``chain.first_end``), consecutive bars welded at a free node forming ternary links (both ends
welded; weld + pin is a pin), torsion springs at the joints, booms from pinned ground nodes
to chain nodes (several as in Configuration 6: all push until the first reaches its length,
then all lock).
Per increment (``feb11_conf1_p1`` / ``_p2``):

1. rebuild the free joints along the chain from the bar angles and the stored bar lengths;
2. equilibrium matrix ``A`` (rows: x, y of the free joints; columns: bar axial forces, one
   moment column per ternary link -- the listing's ``A(:,9) + A(:,11)`` -- and in Part 2 the
   locked boom's axial force);
3. SVD ``A = U S V'``; mechanism modes ``M = U(:, rank+1:end)``; rotation Jacobian ``R_rows``
   (spring rotation = higher-numbered bar minus lower-numbered bar); ``R = R_rows' M``;
4. spring loads ``Load_0 = R_rows q``, ``q = -K (alf_spr - theta0)``; Part 1 adds the boom's
   push along its current line; ``L_app = delta * (load)``;
5. ``phi = (R' K R) \\ (M' L_app)``, joint increments ``d = M phi`` and spring-angle
   increments ``R phi`` (the listing wraps them in ``vpa(., 5)``; rounding them to 5
   significant digits moves Table 4-8's totals in their 6th digit, so the table was not
   computed with rounded increments: ``digits`` defaults to None, no rounding);
6. Part 1 repeats while the boom is not longer than its deployed length; Part 2 (boom locked,
   ``delta`` = 0.5) repeats while ``|U_m' Load_0| >= 1e-6``.

``Lo_tot`` (the sum of ``L_app`` over a part) is what Tables 4-5 to 4-10 print.  The stability
number is the listing's ``ones' U_m' H U_m ones`` with its Hessian as written:
``H = L_app 1' + sum_j lam_j d2F_j`` where ``pd_SE`` is the *first* derivative of the load
work (so each row of the first term repeats one load component) and ``lam`` comes from
``A^+ Load_0`` in the column order of ``A`` (bar I, II, III, ternary moment, IV, V, VI, boom)
while ``F`` is ordered (bar I..VI, boom, bending): the listing pairs them index by index.
Both quirks are kept (``extras`` also holds the eigenvalues of the symmetric part of
``U_m' H U_m``, which do not depend on the SVD's arbitrary null-space basis).  The first term
repeats global load components, so the number changes with the frame and units the structure
is drawn in: it is evaluated in the thesis's own frame (``thesis_frame``: x along the ground
from the last ground joint to the first, the moving joints at positive y, SI units), which
gives the thesis's number for the catalog drawing and the same number for any other drawing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from cases.node_rotation import pinned_ends
from cases.schema import Scene
from cases.units import SYSTEMS
from reduced_models.base import ModelCard, Solution, Step, not_applicable
from reduced_models.thesis.chain import Chain, angles, boom_lengths, read_chain, rebuild, round_sig
from reduced_models.thesis.structure import counts, flexibilities, joint_stiffness

PART1_DELTA = 0.005  # Table 4-2: force fraction gamma for Part 1
PART2_DELTA = 0.5  # ... and for Part 2
PART2_TOL = 1e-6  # N (the listing's SI): while norm(zero_load) >= 1e-6


class ForceMethodState:
    """Matrices of one increment at joint positions ``pos`` (chain order)."""

    def __init__(self, chain: Chain, pos: np.ndarray, lengths: np.ndarray, locked: bool):
        self.pos, self.lengths, self.locked = pos, lengths, locked
        nf = len(chain.free)
        nbar = len(pos) - 1
        th = angles(pos)
        e = np.column_stack([np.cos(th), np.sin(th)])
        n = np.column_stack([-np.sin(th), np.cos(th)])
        row = {j: 2 * k for k, j in enumerate(chain.free)}
        cols = []

        def col(entries: list[tuple[int, np.ndarray]]) -> np.ndarray:
            c = np.zeros(2 * nf)
            for j, v in entries:
                if j in row:
                    c[row[j] : row[j] + 2] += v
            return c

        welded = dict(chain.welds)
        for i in range(nbar):
            cols.append(col([(i, -e[i]), (i + 1, e[i])]))
            if i in welded:  # the ternary link's moment column: A(:,9) + A(:,11)
                k = welded[i]
                cols.append(
                    col(
                        [
                            (i, n[i] / lengths[i]),
                            (i + 1, -n[i] / lengths[i] - n[k] / lengths[k]),
                            (k + 1, n[k] / lengths[k]),
                        ]
                    )
                )
        tip = pos[chain.tip]
        vb = tip - np.asarray(chain.base)
        self.boom_length = float(np.hypot(*vb))
        self.boom_dir = vb / self.boom_length
        if locked:
            cols.append(col([(chain.tip, self.boom_dir)]))
        self.other_dirs = []
        for base, j, _, _ in chain.others:
            vo = pos[j] - np.asarray(base)
            self.other_dirs.append(vo / np.hypot(*vo))
            if locked:
                cols.append(col([(j, self.other_dirs[-1])]))
        self.A = np.column_stack(cols)
        # rotation Jacobian: d(theta_i)/d(x) of every bar, rows = free joint dofs
        dth = np.zeros((2 * nf, nbar))
        for i in range(nbar):
            g = np.array([np.sin(th[i]), -np.cos(th[i])]) / lengths[i]
            for j, v in ((i, g), (i + 1, -g)):
                if j in row:
                    dth[row[j] : row[j] + 2, i] += v
        self.R_rows = np.column_stack(
            [dth[:, a] - (dth[:, b] if b >= 0 else 0.0) for a, b, _, _ in chain.springs]
        )
        self.K = np.diag([s[2] for s in chain.springs])
        U, S, Vt = np.linalg.svd(self.A)
        self.rank = int(np.sum(S > max(self.A.shape) * np.finfo(float).eps * S[0]))  # rank()
        self.U, self.S, self.V = U, S, Vt.T
        self.M = U[:, self.rank :]
        self.R = self.R_rows.T @ self.M

    def spring_load(self, rel: np.ndarray, chain: Chain) -> np.ndarray:
        """``Load_0 = R_rows q``, ``q = -K (rotation - free angle)`` (N), shape (2 nf,)."""
        r_ini = rel - np.array([s[3] for s in chain.springs])
        return self.R_rows @ (-self.K @ r_ini)

    def internal_forces(self, load: np.ndarray) -> np.ndarray:
        """``sigma = sum_i (u_i' P / s_i) v_i`` over the rank (listing, Part 2)."""
        r = self.rank
        return self.V[:, :r] @ ((self.U[:, :r].T @ load) / self.S[:r])


def solve_increment(
    st: ForceMethodState, load: np.ndarray, digits: int | None
) -> tuple[np.ndarray, np.ndarray]:
    """Joint and spring-rotation increments for the applied ``load`` (already times delta)."""
    psi = st.M.T @ load
    phi = np.linalg.solve(st.R.T @ st.K @ st.R, psi)
    d = round_sig(st.M @ phi, digits)
    r_deg = round_sig(st.R @ phi * 180.0 / math.pi, digits)
    return d, np.radians(r_deg)


def constraint_hessians(chain: Chain, lengths: np.ndarray) -> list[np.ndarray]:
    """Hessians of the listing's F_j in the free joint coordinates, in F order: bars, boom,
    bending (one per ternary link)."""
    nf = len(chain.free)
    row = {j: 2 * k for k, j in enumerate(chain.free)}
    I2 = np.eye(2)
    out = []

    def pair(ja: int | None, jb: int, scale: float) -> np.ndarray:
        H = np.zeros((2 * nf, 2 * nf))
        for p, sp in ((ja, 1.0), (jb, -1.0)):
            for q, sq in ((ja, 1.0), (jb, -1.0)):
                if p in row and q in row:
                    H[row[p] : row[p] + 2, row[q] : row[q] + 2] += sp * sq * scale * I2
        return H

    nbar = len(chain.nodes) - 1
    for i in range(nbar):
        out.append(pair(i, i + 1, 1.0 / lengths[i]))
    out.append(pair(None, chain.tip, 1.0 / lengths[nbar]))  # boom: base is ground
    for i, k in chain.welds:  # F = cross(p_w - p_a, p_b - p_w) / (L_i L_k): bilinear
        H = np.zeros((2 * nf, 2 * nf))
        J = np.array([[0.0, 1.0], [-1.0, 0.0]])  # d2/du dv of cross(u, v) = u^T J v
        terms = {i: -1.0, i + 1: 1.0}  # u = p_{i+1} - p_i
        termv = {i + 1: -1.0, k + 1: 1.0}  # v = p_{k+1} - p_{i+1}
        for p, sp in terms.items():
            for q, sq in termv.items():
                if p in row and q in row:
                    blk = sp * sq * J / (lengths[i] * lengths[k])
                    H[row[p] : row[p] + 2, row[q] : row[q] + 2] += blk
                    H[row[q] : row[q] + 2, row[p] : row[p] + 2] += blk.T
        out.append(H)
    for k, (_, j, _, _) in enumerate(chain.others):  # further booms last (order not listed)
        out.append(pair(None, j, 1.0 / lengths[nbar + 1 + k]))
    return out


@dataclass
class PartResult:
    """One part of the computation: joint positions after every increment and the sums."""

    positions: list[np.ndarray]
    boom_lengths: list[float]
    load_total: np.ndarray  # Lo_tot: sum of L_app, shape (2 nf,)
    rel: np.ndarray  # accumulated spring rotations (rad)
    last: ForceMethodState | None = None
    last_app: np.ndarray | None = None
    last_load0: np.ndarray | None = None
    residual: float = math.nan
    stalled: bool = False
    done: bool = False


def run_part(
    chain: Chain,
    pos: np.ndarray,
    lengths: np.ndarray,
    rel: np.ndarray,
    *,
    locked: bool,
    delta: float,
    digits: int | None,
    max_increments: int,
    part2_tol: float = PART2_TOL,
) -> PartResult:
    """Part 1 (``locked=False``: the boom pushes while not longer than its length) or Part 2
    (boom locked; while ``|U_m' Load_0| >= part2_tol``: ``PART2_TOL`` in the scene's force
    unit, so that the answer does not depend on the unit system it is written in).

    As in the listing, the matrices of an increment use the bar angles of the positions the
    previous increment ended at; the increment is added to those positions re-placed along
    the chain with the stored lengths.
    """
    res = PartResult([pos], [], np.zeros(2 * len(chain.free)), rel.copy())
    zero_load = math.inf
    tip = 2 * chain.free.index(chain.tip)
    for _ in range(max_increments):
        st = ForceMethodState(chain, pos, lengths, locked)
        res.boom_lengths.append(st.boom_length)
        if (not locked and st.boom_length > chain.length) or zero_load < part2_tol:
            res.done = True
            break
        load0 = st.spring_load(res.rel, chain)
        load = load0.copy()
        if not locked:
            load[tip : tip + 2] += chain.force * st.boom_dir
            for (_, j, force, _), e in zip(chain.others, st.other_dirs):  # pushed on (thesis)
                k = 2 * chain.free.index(j)
                load[k : k + 2] += force * e
        app = delta * load
        d, dr = solve_increment(st, app, digits)
        res.load_total = res.load_total + app
        res.rel = res.rel + dr
        if locked:
            zero_load = float(np.linalg.norm(st.M.T @ load0))
        res.last, res.last_app, res.last_load0 = st, app, load0
        pos = rebuild(pos, lengths)
        pos[1:-1] += d.reshape(-1, 2)
        res.positions.append(pos)
        if not locked and np.linalg.norm(d) < 1e-12 * chain.length:
            res.stalled = True  # the boom balances the springs short of its length
            break
    res.residual = zero_load
    return res


def thesis_frame(scene: Scene, chain: Chain) -> tuple[np.ndarray, float, float]:
    """The frame and units the thesis draws the structure in: (Q, metres per length unit,
    newtons per force unit), Q (2, 2) orthogonal taking scene vectors to the frame whose x
    axis runs along the ground from the chain's last ground joint to its first and whose y
    points to the side the drawn moving joints are on (SI; ``nondim`` scenes as they are).

    The listing's stability number is not frame-invariant (its ``pd_SE`` term repeats the
    global load components): evaluated in this frame it is the thesis's own number for
    every drawing of the same structure."""
    xy = np.array([[scene.node(j).x, scene.node(j).y] for j in chain.nodes])
    ex = xy[0] - xy[-1]
    ex = ex / np.hypot(*ex)
    Q = np.array([[ex[0], ex[1]], [-ex[1], ex[0]]])
    side = np.sum((xy[list(chain.free)] - xy[-1]) @ Q[1])
    if side < 0.0:  # drawn mirrored: turn y
        Q = np.array([[1.0, 0.0], [0.0, -1.0]]) @ Q
    sL, sF = SYSTEMS.get(scene.units, (1.0, 1.0))
    return Q, sL, sF


def thesis_stability(scene: Scene, chain: Chain, part2: PartResult, lengths: np.ndarray) -> dict:
    """The listing's stability number, evaluated in the thesis's frame (``thesis_frame``),
    and, beside it, basis-free eigenvalues."""
    Q, sL, sF = thesis_frame(scene, chain)

    def vec(v: np.ndarray, s: float) -> np.ndarray:  # per-joint (x, y) rows into the frame
        return s * (v.reshape(-1, 2) @ Q.T).reshape(-1)

    last = part2.last
    canon = replace(
        chain,
        base=tuple(vec(np.asarray(chain.base), sL)),
        others=tuple((tuple(vec(np.asarray(b), sL)), j, f, sL * L) for b, j, f, L in chain.others),
    )
    st = ForceMethodState(canon, vec(last.pos, sL).reshape(-1, 2), sL * last.lengths, last.locked)
    app = vec(part2.last_app, sF)
    lam = st.internal_forces(vec(part2.last_load0, sF))
    H = np.outer(app, np.ones(len(app)))  # pd_SE as written
    for lj, Hj in zip(lam, constraint_hessians(chain, sL * lengths)):  # index-by-index pairing
        H = H + lj * Hj
    Um = st.M
    mat = Um.T @ H @ Um
    ones = np.ones(Um.shape[1])
    return {
        "stability_number": float(ones @ mat @ ones),
        "stability_matrix": mat.tolist(),
        "stability_eigs_sym": np.linalg.eigvalsh(0.5 * (mat + mat.T)).tolist(),
        "internal_forces": lam.tolist(),
    }


def structure(
    scene: Scene, chain: Chain, p1: PartResult, p2: PartResult, lengths: np.ndarray
) -> dict:
    """Counts before the lock (start of Part 1) and deployed (Part 2's last matrices), and
    the deployed structure's stiffness at J4 (or the first boom's joint), Eqs. 2-46 to 2-48."""
    start = ForceMethodState(chain, p1.positions[0], lengths[: len(chain.nodes) - 1], False)
    st = p2.last
    node = "J4" if "J4" in [chain.nodes[j] for j in chain.free] else chain.nodes[chain.tip]
    row = 2 * chain.free.index(chain.nodes.index(node))
    c = flexibilities(scene, chain, lengths, st.A.shape[1])
    out = {"start": counts(start.A, start.rank), "deployed": counts(st.A, st.rank)}
    out["joint"] = node
    out.update(joint_stiffness(st.A, c, st.R_rows, st.K, row))
    return out


def _rot(scene: Scene, chain: Chain, turn: np.ndarray, node: str) -> float:
    """Output rotation (rad) of a chain node from the bar rotations ``turn`` (chain order):
    the first welded bar end's there, else the mean over its pinned bar ends
    (``cases.node_rotation``)."""
    bar = {m.id: chain.bars.index(i) for i, m in enumerate(scene.members)}
    ends = pinned_ends(scene.members, node)
    if ends:
        return float(np.mean([turn[bar[mid]] for mid, _ in ends]))
    first = next(
        m.id
        for m in scene.members
        if (m.a == node and m.end_a == "weld") or (m.b == node and m.end_b == "weld")
    )
    return float(turn[bar[first]])


class ThesisForceMethod:
    """``thesis-force-method``: the thesis's Appendix C incremental force method.

    Parameters
    ----------
    delta1, delta2 : force fractions gamma of Part 1 and Part 2 (thesis: 0.005 and 0.5).
    digits : significant digits the increments are rounded to (the listing's ``vpa(., 5)``
        taken literally); None (default): no rounding, which reproduces Table 4-8.
    max_increments : bound on the increments of each part.
    """

    name = "thesis-force-method"
    # the thesis's linearised increments let its rigid bars drift in length (2.3e-4 relative
    # on Configuration 6, whose second boom it pushes past its length): that is the method's
    # own error, measured against kinetostatic like any model's, not a failed solve
    rigid_link_drift = 1e-2
    OPTIONS: dict = {}  # declared options (reduced_models.options): none
    card = ModelCard(
        name="thesis-force-method",
        family="mechanism",
        summary="Incremental force method of the six-bar thesis (Appendix C): SVD of the "
        "equilibrium matrix, mechanism modes, spring stiffness, load fractions",
        assumptions=(
            "rigid bars, pin joints, ternary links as welded bar pairs (one moment column)",
            "boom: constant push along its line until longer than its length, then a bar; "
            "further booms push until the first is that long (the thesis's Configuration 6)",
            "each increment applies delta times the whole current load through the modal "
            "spring stiffness R'KR (a relaxation, not a Newton step)",
            "stability number ones' U_m' H U_m ones with the listing's Hessian as written, "
            "evaluated in the thesis's frame (x along the ground, the chain above it, SI)",
        ),
        validity="serial six-bar chains of the thesis; accuracy set by delta (see report)",
        references=(
            "seed 001_427a1482c4f4c482.txt, Chapter 2 and Appendix C (feb11_conf1_p1/_p2, "
            "Jac_Hess_feb11_conf1); Tables 4-2 and 4-8",
            "Pellegrino & Calladine (1986), Int. J. Solids Struct. 22(4) 409-428",
        ),
    )

    def __init__(
        self,
        delta1: float = PART1_DELTA,
        delta2: float = PART2_DELTA,
        digits: int | None = None,
        max_increments: int = 20000,
    ) -> None:
        for key, v in (("delta1", delta1), ("delta2", delta2)):
            if isinstance(v, bool) or not isinstance(v, int | float) or not 0.0 < v <= 1.0:
                raise ValueError(f"option {key}: must be a number in (0, 1], got {v!r}")
        if digits is not None and (
            isinstance(digits, bool) or not isinstance(digits, int) or not 1 <= digits <= 17
        ):
            raise ValueError(f"option digits: an integer in 1..17 or absent, got {digits!r}")
        if isinstance(max_increments, bool) or not isinstance(max_increments, int):
            raise ValueError(f"option max_increments: a positive integer, got {max_increments!r}")
        if max_increments < 1:
            raise ValueError(f"option max_increments: a positive integer, got {max_increments!r}")
        self.delta1, self.delta2 = float(delta1), float(delta2)
        self.digits, self.max_increments = digits, max_increments

    def applies_to(self, scene: Scene) -> str | None:
        """None for a deploy of a thesis-family chain, else why not."""
        if scene.analysis.kind != "deploy":
            return "the thesis's force method computes deploy analyses only"
        chain = read_chain(scene)
        return chain if isinstance(chain, str) else None

    def run(self, scene: Scene) -> tuple[Chain, PartResult, PartResult | None]:
        """Both parts (Part 2 None when the boom stalled or Part 1 ran out of increments)."""
        chain = read_chain(scene)
        pos = np.array([[scene.node(j).x, scene.node(j).y] for j in chain.nodes])
        lengths = np.hypot(*np.diff(pos, axis=0).T)
        newtons = SYSTEMS.get(scene.units, (1.0, 1.0))[1]  # per force unit of the scene
        opts = {"digits": self.digits, "max_increments": self.max_increments}
        p1 = run_part(
            chain, pos, lengths, np.zeros(len(chain.springs)), locked=False,
            delta=self.delta1, **opts,
        )  # fmt: skip
        if not p1.done:
            return chain, p1, None
        end = p1.positions[-1]
        lengths2 = np.hypot(*np.diff(end, axis=0).T)  # L_f: Part 2 uses the reached lengths
        p2 = run_part(
            chain, end, lengths2, p1.rel, locked=True, delta=self.delta2,
            part2_tol=PART2_TOL / newtons, **opts,
        )  # fmt: skip
        return chain, p1, p2

    def solve(self, scene: Scene) -> Solution:
        """Part 1 then Part 2; steps at Part 1 report points, last step = Part 2."""
        why = self.applies_to(scene)
        if why:
            return not_applicable(scene, self.name, why)
        chain, p1, p2 = self.run(scene)
        extras: dict[str, object] = {
            # Part 1's states are a relaxation in pseudo-time (each increment moves by delta
            # times the unbalanced load), not equilibria, and its first is the drawn pose:
            # only the last step (Part 2, the equilibrium) is compared with a reference
            "judged_steps": "last",
            "load_total_rows": [f"{chain.nodes[j]}.{c}" for j in chain.free for c in "xy"],
            "part1_increments": len(p1.positions) - 1,
            "part1_load_total": p1.load_total.tolist(),
            "part1_boom_length": p1.boom_lengths,
        }
        if p2 is None:
            last = p1.boom_lengths[-1]
            if p1.stalled:
                msg = f"boom {scene.booms[0].id!r} stalled at length {last:.6g} < {chain.length:g}"
                return self._solution(scene, chain, p1, None, "converged", msg, extras)
            msg = f"Part 1: {self.max_increments} increments at boom length {last:.6g}"
            return self._solution(scene, chain, p1, None, "failed", msg, extras)
        end = p1.positions[-1]
        reached = boom_lengths(chain, end)
        lengths = np.append(np.hypot(*np.diff(end, axis=0).T), reached)
        extras.update(thesis_stability(scene, chain, p2, lengths))
        extras["part1_boom_lengths_end"] = dict(zip([b.id for b in scene.booms], reached))
        extras["part2_increments"] = len(p2.positions) - 1
        extras["part2_load_total"] = p2.load_total.tolist()
        extras["part2_residual"] = p2.residual
        extras["structure"] = structure(scene, chain, p1, p2, lengths)
        ok = p2.done
        msg = (
            f"Part 1: {len(p1.positions) - 1} increments; Part 2: {len(p2.positions) - 1} "
            f"increments, |U_m' Load_0| = {p2.residual:.2e} N; stability number "
            f"{extras['stability_number']:.4g}"
        )
        for b, L in zip(scene.booms[1:], reached[1:]):
            if L > b.length:  # the thesis's Part 1 stops on the first boom only
                msg += (
                    f"; boom {b.id!r} pushed on past its {b.length:g} to {L:.6g} (the thesis's "
                    f"Part 1 stops when {scene.booms[0].id!r} reaches its length)"
                )
        if not ok:
            msg = f"Part 2 did not settle in {self.max_increments} increments; " + msg
        return self._solution(scene, chain, p1, p2, "converged" if ok else "failed", msg, extras)

    def _solution(
        self,
        scene: Scene,
        chain: Chain,
        p1: PartResult,
        p2: PartResult | None,
        status: str,
        msg: str,
        extras: dict,
    ) -> Solution:
        """Steps: Part 1 at ``steps`` + 1 report points of boom extension, then Part 2."""
        L0, Lend = p1.boom_lengths[0], chain.length
        prog = (np.array(p1.boom_lengths) - L0) / (Lend - L0)
        picks = []
        for target in np.linspace(0.0, 1.0, scene.analysis.steps + 1):
            hit = np.nonzero(prog >= target - 1e-12)[0]
            picks.append(int(hit[0]) if hit.size else len(prog) - 1)
        steps = []
        for k in dict.fromkeys(picks):
            steps.append(self._step(scene, chain, p1.positions[k], float(prog[k])))
        if p2 is not None:
            st = self._step(scene, chain, p2.positions[-1], 2.0)
            stable = extras["stability_number"] > 0
            steps.append(Step(st.factor, st.outputs, stable=bool(stable), info=st.info))
        return Solution(scene.name, self.name, status, msg, tuple(steps), extras)

    @staticmethod
    def _step(scene: Scene, chain: Chain, pos: np.ndarray, factor: float) -> Step:
        where = dict(zip(chain.nodes, pos))
        turn = angles(pos) - angles(
            np.array([[scene.node(j).x, scene.node(j).y] for j in chain.nodes])
        )
        turn = (turn + math.pi) % (2 * math.pi) - math.pi  # bar rotations (rad)
        out = {}
        for o in scene.outputs:
            n = scene.node(o.node)
            x, y = where.get(o.node, (n.x, n.y))
            out |= {f"{o.name}.x": x, f"{o.name}.y": y, f"{o.name}.ux": x - n.x}
            out |= {f"{o.name}.uy": y - n.y, f"{o.name}.rot": _rot(scene, chain, turn, o.node)}
        for b, L in zip(scene.booms, boom_lengths(chain, pos)):
            out[f"{b.id}.length"] = L
        return Step(factor=factor, outputs=out)
