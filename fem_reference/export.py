"""Export deformed shapes: VTU files and an XDMF time series (meshio), PNG renders (pyvista).

* ``write_vtu`` writes one state: every member's centre line as ``("line", conn)`` cells, points
  padded to 3-D (z = 0), optional point fields per member.
* ``write_series`` writes a ``Solution``: one VTU per step with the *deformed* points, a ``.pvd``
  collection of them (ParaView/pyvista open it as a deforming time series), and an XDMF time
  series (mesh = first step's shapes, per step a ``displacement`` vector field -- apply
  ParaView's *Warp By Vector* -- plus the scalar fields).  An XDMF time series stores one mesh
  for all steps, hence the displacement formulation.  Data are inline XML (``data_format="XML"``)
  so no h5py is needed; the files of a benchmark scene are small.
* ``render_png`` renders the deformed scene off-screen with pyvista when a child-process probe
  shows that VTK can render here (without EGL or OSMesa libraries VTK segfaults, which would
  kill the caller); otherwise it draws the same picture with matplotlib.

Point fields
------------
``curvature`` (1/length) is always written, recovered from the polyline itself:
``2 sin(turn / 2)`` at a vertex over the mean length of its two segments (exact for equally
spaced points on a circle; end vertices copy their neighbour).  That is a geometric estimate;
a solver that knows its curvature, axial force or bending stress passes them in
``point_data`` / ``fields`` and they are written as given (a given ``curvature`` replaces the
geometric one).

A series (``write_series``) adds per step, against its first step (the unloaded scene for
analyses that start at load factor 0): ``displacement`` (3-vector, length), ``rotation``
(rad, of the centre line's tangent), ``load_factor``; with ``sections`` (``member_sections``:
E I and E t / 2 per flexible member) also ``bending_moment`` = E I (kappa - kappa_0) (force x
length) and ``bending_stress`` = E t (kappa - kappa_0) / 2 (stress; NaN where the member has
no thickness).  Each step's time value (``series_times``) is the PVD ``timestep`` and the
XDMF time.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path

import meshio
import numpy as np

from cases.schema import Scene
from reduced_models.base import Solution, Step

__all__ = [
    "last_render_backend",
    "member_sections",
    "node_fields",
    "polyline_curvature",
    "pyvista_available",
    "render_png",
    "series_times",
    "write_series",
    "write_vtu",
]

PointData = Mapping[str, Mapping[str, np.ndarray]]

# --- geometry --------------------------------------------------------------------------------


def polyline_curvature(points: np.ndarray) -> np.ndarray:
    """Signed curvature estimate at the vertices of a polyline.

    Parameters
    ----------
    points : (n, 2) vertex coordinates (length units).

    Returns
    -------
    (n,) curvature (1/length), counter-clockwise turning positive; zeros for n < 3.
    """
    p = np.asarray(points, dtype=float)
    n = len(p)
    if n < 3:
        return np.zeros(n)
    d = np.diff(p, axis=0)
    seg = np.hypot(d[:, 0], d[:, 1])
    ang = np.arctan2(d[:, 1], d[:, 0])
    turn = np.angle(np.exp(1j * np.diff(ang)))  # wrapped to (-pi, pi]
    kap = np.empty(n)
    # 2 sin(turn/2) / mean segment: exact for equally spaced points on a circle
    mean_seg = 0.5 * (seg[:-1] + seg[1:])
    num = 2.0 * np.sin(0.5 * turn)
    kap[1:-1] = np.divide(num, mean_seg, out=np.zeros_like(num), where=mean_seg > 0)
    kap[0], kap[-1] = kap[1], kap[-2]
    return kap


def _assemble(
    shapes: Mapping[str, np.ndarray], point_data: PointData | None
) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray], np.ndarray]:
    """Stack members into (points (P, 3), line conn (C, 2), point fields, cell member index)."""
    if not shapes:
        raise ValueError("no shapes to export")
    pts, conn, member_idx, offset = [], [], [], 0
    sizes = {}
    for i, (mid, xy) in enumerate(shapes.items()):
        xy = np.asarray(xy, dtype=float)
        if xy.ndim != 2 or xy.shape[1] != 2 or len(xy) < 2:
            raise ValueError(f"shape of member {mid!r} must be (n >= 2, 2), got {xy.shape}")
        n = len(xy)
        sizes[mid] = n
        pts.append(np.column_stack([xy, np.zeros(n)]))
        idx = np.arange(offset, offset + n)
        conn.append(np.column_stack([idx[:-1], idx[1:]]))
        member_idx.append(np.full(n - 1, i, dtype=np.int32))
        offset += n
    fields: dict[str, np.ndarray] = {
        "curvature": np.concatenate([polyline_curvature(xy) for xy in shapes.values()])
    }
    for name, per_member in (point_data or {}).items():
        parts = []
        tail = np.shape(next(iter(per_member.values()), ()))[1:]  # () scalar, (3,) vector
        for mid, n in sizes.items():
            if mid in per_member:
                a = np.asarray(per_member[mid], dtype=float)
                if a.shape[0] != n:
                    raise ValueError(
                        f"field {name!r} of member {mid!r} has {a.shape[0]} values, "
                        f"shape has {n} points"
                    )
                parts.append(a)
            else:
                parts.append(np.full((n, *tail), np.nan))
        fields[name] = np.concatenate(parts)
    return np.vstack(pts), np.vstack(conn), fields, np.concatenate(member_idx)


def write_vtu(
    path: str | Path,
    shapes: Mapping[str, np.ndarray],
    point_data: PointData | None = None,
) -> Path:
    """Write one deformed state as a VTU file.

    Parameters
    ----------
    path : output file (``.vtu``); parent directories are created.
    shapes : member id -> (n, 2) centre-line points (length units), in a fixed order.
    point_data : field name -> {member id -> (n,) values}; members missing from a field get
        NaN.  ``curvature`` is computed from the shapes unless given here.

    Returns
    -------
    The path written.  Cell data ``member`` holds each line cell's member index (order of
    ``shapes``).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    points, conn, fields, member = _assemble(shapes, point_data)
    mesh = meshio.Mesh(points, [("line", conn)], point_data=fields, cell_data={"member": [member]})
    mesh.write(path)
    return path


def _resample(xy: np.ndarray, n: int) -> np.ndarray:
    """(m, 2) polyline resampled to n points at equal fractions of its point index."""
    xy = np.asarray(xy, dtype=float)
    if len(xy) == n:
        return xy
    t_old, t_new = np.linspace(0.0, 1.0, len(xy)), np.linspace(0.0, 1.0, n)
    return np.column_stack([np.interp(t_new, t_old, xy[:, 0]), np.interp(t_new, t_old, xy[:, 1])])


def member_sections(scene: Scene) -> dict[str, tuple[float, float]]:
    """Member id -> (E I, E t / 2) of each flexible member: bending moment and bending
    stress per unit curvature (E t / 2 is NaN where the member has no thickness)."""
    return {
        m.id: (m.EI, m.E * m.thickness / 2.0 if m.E and m.thickness else np.nan)
        for m in scene.members
        if m.kind == "flexible"
    }


def _tangent_angle(xy: np.ndarray) -> np.ndarray:
    """Angle (rad, unwrapped along the polyline) of its tangent at the vertices: the mean of
    the two adjacent chords' angles inside; at an end extrapolated from the chord angles at
    their mid-points (a parabola through three, a line through two).  Exact, like
    ``polyline_curvature``, for equally spaced points on a circle, and with three chords for
    curvature varying linearly (a cantilever's root under a tip load)."""
    d = np.diff(xy, axis=0)
    a = np.unwrap(np.arctan2(d[:, 1], d[:, 0]))
    if len(a) == 1:
        return np.repeat(a, 2)
    inner = 0.5 * (a[:-1] + a[1:])
    # value at s = 0 of the polynomial through (0.5, a0), (1.5, a1)[, (2.5, a2)]
    w = np.array([15.0, -10.0, 3.0]) / 8.0 if len(a) >= 3 else np.array([1.5, -0.5])
    k = len(w)
    return np.concatenate([[w @ a[:k]], inner, [w @ a[::-1][:k]]])


def node_fields(
    shapes: Mapping[str, np.ndarray],
    ref_shapes: Mapping[str, np.ndarray],
    sections: Mapping[str, tuple[float, float]] | None = None,
) -> dict[str, dict[str, np.ndarray]]:
    """Point fields of one state against a reference state with the same point counts.

    Parameters
    ----------
    shapes, ref_shapes : member id -> (n, 2) centre-line points (length units).
    sections : member id -> (E I, E t / 2) (``member_sections``); members not in it get
        no bending fields.

    Returns
    -------
    field -> {member -> values}: ``displacement`` (n, 3) (z = 0), ``rotation`` (n,) rad
    (turning counter-clockwise positive, the first vertex's wrapped to (-pi, pi]), and with
    ``sections`` ``bending_moment`` (n,) and ``bending_stress`` (n,) from the curvature
    change.
    """
    out: dict[str, dict[str, np.ndarray]] = {"displacement": {}, "rotation": {}}
    if sections:
        out |= {"bending_moment": {}, "bending_stress": {}}
    for mid, xy in shapes.items():
        xy, xy0 = np.asarray(xy, dtype=float), np.asarray(ref_shapes[mid], dtype=float)
        u = xy - xy0
        out["displacement"][mid] = np.column_stack([u, np.zeros(len(u))])
        rot = _tangent_angle(xy) - _tangent_angle(xy0)
        out["rotation"][mid] = rot - 2.0 * np.pi * np.round(rot[0] / (2.0 * np.pi))
        if sections and mid in sections:
            dk = polyline_curvature(xy) - polyline_curvature(xy0)
            ei, et2 = sections[mid]
            out["bending_moment"][mid] = ei * dk
            out["bending_stress"][mid] = et2 * dk
    return out


def series_times(steps: Sequence[Step]) -> np.ndarray:
    """Time value of each state of a series, shape (n,): ``info["t"]`` where every step has
    one (the replay's frames, seconds), else the load factor where it rises strictly (a
    ``load`` analysis), else the step index (a path through a limit point revisits
    factors; ParaView orders a series by its time values)."""
    t = [s.info.get("t") for s in steps]
    if steps and all(v is not None for v in t):
        return np.asarray(t, dtype=float)
    f = np.array([s.factor for s in steps], dtype=float)
    return f if len(f) > 1 and np.all(np.diff(f) > 0) else np.arange(len(f), dtype=float)


def write_series(
    directory: str | Path,
    solution: Solution,
    fields: Sequence[PointData | None] | None = None,
    sections: Mapping[str, tuple[float, float]] | None = None,
) -> Path:
    """Write every step of a solution: VTU per step, a ``.pvd`` collection, an XDMF series.

    Parameters
    ----------
    directory : output directory (created).
    solution : a ``Solution`` whose steps carry ``shapes``; steps without shapes are skipped.
    fields : optional per-step point data (same layout as ``write_vtu``'s ``point_data``),
        one entry per step of ``solution.steps`` (``None`` entries allowed), e.g. axial force
        and bending stress recovered by the FE system.
    sections : member id -> (E I, E t / 2) (``member_sections(scene)``): adds the bending
        moment and stress fields.

    Returns
    -------
    Path of the ``.xdmf`` file.  Every VTU and XDMF step holds ``displacement``, ``rotation``
    (and with ``sections`` the bending fields) against the first step (``node_fields``) and
    ``load_factor``; time is ``series_times``.  Members whose point count changes between
    steps are resampled to the first step's count (XDMF holds one mesh).
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    if fields is not None and len(fields) != len(solution.steps):
        raise ValueError(f"fields has {len(fields)} entries, solution {len(solution.steps)} steps")
    indexed = [(k, s) for k, s in enumerate(solution.steps) if s.shapes]
    if not indexed:
        raise ValueError(f"solution {solution.case}/{solution.model} has no shapes to export")
    stem = f"{solution.case}_{solution.model}".replace("/", "_") or "solution"
    ref_shapes = {m: np.asarray(xy, dtype=float) for m, xy in indexed[0][1].shapes.items()}
    ref_points, ref_conn, _, member = _assemble(ref_shapes, None)
    xdmf_path = directory / f"{stem}.xdmf"
    pvd_entries = []
    times = series_times([s for _, s in indexed])
    with meshio.xdmf.TimeSeriesWriter(xdmf_path, data_format="XML") as writer:
        writer.write_points_cells(ref_points, [("line", ref_conn)])
        for i, (k, step) in enumerate(indexed):
            shapes = {m: _resample(step.shapes.get(m, xy), len(xy)) for m, xy in ref_shapes.items()}
            extra = node_fields(shapes, ref_shapes, sections)
            extra["load_factor"] = {
                m: np.full(len(xy), float(step.factor)) for m, xy in shapes.items()
            }
            extra |= dict(fields[k] or {}) if fields is not None else {}
            vtu = write_vtu(directory / f"{stem}_{i:04d}.vtu", shapes, extra)
            pvd_entries.append((times[i], vtu.name))
            _, _, pdata, _ = _assemble(shapes, extra)
            writer.write_data(times[i], point_data=pdata, cell_data={"member": [member]})
    _write_pvd(directory / f"{stem}.pvd", pvd_entries)
    return xdmf_path


def _write_pvd(path: Path, entries: list[tuple[float, str]]) -> None:
    """ParaView collection file listing the per-step VTUs with their time values."""
    rows = "\n".join(
        f'    <DataSet timestep="{float(t)!r}" group="" part="0" file="{name}"/>'
        for t, name in entries
    )
    path.write_text(
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
        f"{rows}\n  </Collection>\n</VTKFile>\n"
    )


# --- rendering -------------------------------------------------------------------------------

_PROBE = """
import pyvista as pv
p = pv.Plotter(off_screen=True, window_size=(48, 32))
p.add_mesh(pv.Line((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)))
img = p.screenshot(return_img=True)
p.close()
assert img.shape[:2] == (32, 48), img.shape
print("FLEXBENCH_PYVISTA_OK", flush=True)
"""
_ENV_KEY = "_FLEXBENCH_PYVISTA_OK"  # verdict handed down to child processes (pool workers)
_verdict: bool | None = None
_TAB10 = (
    "tab:blue",
    "tab:orange",
    "tab:green",
    "tab:red",
    "tab:purple",
    "tab:brown",
    "tab:pink",
    "tab:gray",
    "tab:olive",
    "tab:cyan",
)  # same colours as matplotlib's default cycle
_last_backend: str | None = None


def pyvista_available(timeout: float = 60.0) -> bool:
    """Whether pyvista can render off-screen here, probed once in a child process.

    A VTK build without an EGL or OSMesa library segfaults on the first render, so the probe
    runs ``_PROBE`` in a subprocess (``timeout`` seconds) and never in this process.  The
    verdict is cached in the module and in the environment variable ``_FLEXBENCH_PYVISTA_OK``
    (inherited by worker processes started later); set ``FLEXBENCH_RENDER=matplotlib`` to
    skip pyvista altogether.
    """
    global _verdict
    if os.environ.get("FLEXBENCH_RENDER", "").lower() == "matplotlib":
        return False
    if _verdict is None:
        cached = os.environ.get(_ENV_KEY)
        if cached in ("0", "1"):
            _verdict = cached == "1"
        else:
            try:
                proc = subprocess.run(
                    [sys.executable, "-c", _PROBE],
                    capture_output=True,
                    text=True,
                    timeout=timeout,
                    check=False,
                )
                _verdict = proc.returncode == 0 and "FLEXBENCH_PYVISTA_OK" in proc.stdout
            except (OSError, subprocess.TimeoutExpired):
                _verdict = False
            os.environ[_ENV_KEY] = "1" if _verdict else "0"
    return _verdict


def _bounds(*groups: Mapping[str, np.ndarray] | None) -> tuple[float, float, float, float]:
    pts = np.vstack([np.asarray(xy, float) for g in groups if g for xy in g.values()])
    return pts[:, 0].min(), pts[:, 0].max(), pts[:, 1].min(), pts[:, 1].max()


def _render_pyvista(
    path: Path,
    shapes: Mapping[str, np.ndarray],
    reference_shapes: Mapping[str, np.ndarray] | None,
    title: str,
) -> None:
    import pyvista as pv  # imported only after the probe said rendering is safe

    def polyline(xy: np.ndarray) -> pv.PolyData:
        xy = np.asarray(xy, dtype=float)
        return pv.lines_from_points(np.column_stack([xy, np.zeros(len(xy))]))

    if hasattr(pv, "vtk_verbosity"):
        # VTK tries X11 before EGL and logs "bad X server connection" on a headless machine
        pv.vtk_verbosity("off")
    plotter = pv.Plotter(off_screen=True, window_size=(1200, 900))
    plotter.set_background("white")
    for xy in (reference_shapes or {}).values():
        plotter.add_mesh(polyline(xy), color="lightgray", line_width=2)
    for i, xy in enumerate(shapes.values()):
        plotter.add_mesh(polyline(xy), color=_TAB10[i % len(_TAB10)], line_width=5)
        ends = np.asarray(xy, dtype=float)[[0, -1]]
        plotter.add_points(
            np.column_stack([ends, np.zeros(2)]),
            color="black",
            point_size=10,
            render_points_as_spheres=True,
        )
    if title:
        plotter.add_text(title, font_size=12, color="black")
    plotter.view_xy()
    plotter.enable_parallel_projection()
    plotter.reset_camera()
    plotter.screenshot(str(path))
    plotter.close()


def _render_matplotlib(
    path: Path,
    shapes: Mapping[str, np.ndarray],
    reference_shapes: Mapping[str, np.ndarray] | None,
    title: str,
) -> None:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 6), dpi=150)
    for xy in (reference_shapes or {}).values():
        xy = np.asarray(xy, dtype=float)
        ax.plot(xy[:, 0], xy[:, 1], color="0.75", lw=1.5, ls="--")
    for mid, xy in shapes.items():
        xy = np.asarray(xy, dtype=float)
        ax.plot(xy[:, 0], xy[:, 1], lw=2.5, label=str(mid))
        ax.plot(xy[[0, -1], 0], xy[[0, -1], 1], "k.", ms=8)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    if title:
        ax.set_title(title)
    if 1 < len(shapes) <= 12:
        ax.legend(fontsize="small")
    ax.grid(alpha=0.3)
    fig.savefig(path)
    plt.close(fig)


def render_png(
    path: str | Path,
    shapes: Mapping[str, np.ndarray],
    reference_shapes: Mapping[str, np.ndarray] | None = None,
    title: str = "",
    *,
    backend: str = "auto",
) -> Path:
    """Render the deformed scene (and optionally the undeformed one) to a PNG.

    Parameters
    ----------
    path : output PNG (parent directories created).
    shapes : member id -> (n, 2) deformed centre lines.
    reference_shapes : member id -> (n, 2) undeformed centre lines, drawn light grey.
    title : caption.
    backend : ``auto`` (pyvista if ``pyvista_available()``, else matplotlib), ``pyvista``
        (raises RuntimeError if the probe fails) or ``matplotlib``.

    Returns
    -------
    The path written.  ``last_render_backend()`` names the backend that drew it.
    """
    if not shapes:
        raise ValueError("no shapes to render")
    _bounds(shapes, reference_shapes)  # validates the arrays before any renderer starts
    if backend not in ("auto", "pyvista", "matplotlib"):
        raise ValueError(f"backend must be auto, pyvista or matplotlib, got {backend!r}")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    use_pv = backend == "pyvista" or (backend == "auto" and pyvista_available())
    if use_pv and not pyvista_available():
        raise RuntimeError("pyvista cannot render off-screen here (no EGL/OSMesa?)")
    if use_pv:
        _render_pyvista(path, shapes, reference_shapes, title)
    else:
        _render_matplotlib(path, shapes, reference_shapes, title)
    global _last_backend
    _last_backend = "pyvista" if use_pv else "matplotlib"
    return path


def last_render_backend() -> str | None:
    """``pyvista`` or ``matplotlib``: what drew the last ``render_png`` picture (None: none yet)."""
    return _last_backend
