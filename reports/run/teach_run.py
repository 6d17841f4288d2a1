"""The teaching page inside ``flexbench run``: atlases as pool jobs, cached; advice from the run.

``flexbench teach`` builds the page by itself (minutes: it runs the recommender's ladders on
every catalog case).  A run already holds most of what the page needs, so here:

* **validity atlases** (``reports.verdicts.atlas``, one job per load family) and the **cost
  scaling** and **deformed shapes** (one job) are pool jobs queued first, so they solve beside the
  case pairs instead of after them; on one worker or Dask they run in this process at the end;
* each job's result is cached in ``OUT/teaching-cache/<part>-<grid>-<key>.json``, the key
  hashing the solver packages' sources (``tables.code_hash``), the atlas and page modules,
  the model list and the grid: a rerun (``--fresh`` included: the key already says when a
  result is stale) or a resumed run with the same code reuses it;
* the **worked advice** per case is the recommender's judgement and pick
  (``reports.verdicts.advice.from_records``: the front page's too) applied to the models this run
  solved, at their shared cost estimates (``reports.verdicts.cost``): no extra solve.  It differs
  from ``flexbench recommend`` where the recommender's ladders try an N the run did not
  (e.g. ``prb-fsm-32``); the page says so.

Grid: ``GRID`` (40 magnitudes x 41 directions) by default, ``QUICK_GRID`` with ``--quick``.
"""

from __future__ import annotations

import hashlib
import json
import time
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from reports.run import limits
from reports.verdicts import atlas

ROLE = "teaching"  # the ``role`` of a teaching job and of what it returns
CACHE_DIR = "teaching-cache"
GRID = (40, 41)  # (load magnitudes, directions) of the force and follower atlases
QUICK_GRID = (20, 21)
TOLERANCES = ("1%", "0.1%")
MECH_N_AXIS = 5  # second-axis values of the mechanism atlases (as ``flexbench teach``)


def mech_n_axis(grid: tuple[int, int]) -> int:
    """Second-axis values of the mechanism atlases for a grid: ``MECH_N_AXIS`` at ``GRID``,
    fewer on coarser grids (3 with ``--quick``: a mechanism atlas costs ~1-1.5 s CPU per
    axis value, a force-atlas direction ~0.15 s)."""
    return max(2, min(MECH_N_AXIS, grid[1] // 7))


_SOURCES = (
    "reports/verdicts/atlas.py",
    "reports/verdicts/atlas_mech.py",
    "reports/verdicts/claims.py",
    "reports/verdicts/claims_howell.py",
    "reports/render/teaching.py",
    "reports/render/mech_atlas.py",
    "reports/api.py",
)


def parts() -> tuple[str, ...]:
    """The cached pieces: one per atlas family, ``extras`` (cost scaling, shapes) and one
    mechanism atlas per ``mech_atlas.TEACH_CASES`` case (``mech-<case>``)."""
    from reports.render import mech_atlas

    return (*atlas.FAMILIES, "extras", *(f"mech-{c}" for c in mech_atlas.TEACH_CASES))


def cache_key(part: str, grid: tuple[int, int], code: str) -> str:
    """Hash of what a part's result depends on: solver code, page code, models, grid."""
    h = hashlib.sha1(f"{code}|{part}|{grid}|{atlas.MODELS}".encode())
    root = Path(__file__).resolve().parents[2]  # the repository: _SOURCES are relative to it
    for rel in _SOURCES:
        h.update((root / rel).read_bytes())
    return h.hexdigest()[:12]


def cache_path(out_dir: Path, part: str, grid: tuple[int, int], code: str) -> Path:
    """Where ``part``'s cached result lives."""
    name = f"{part}-{grid[0]}x{grid[1]}-{cache_key(part, grid, code)}.json"
    return Path(out_dir) / CACHE_DIR / name


def plan_jobs(
    out_dir: Path, grid: tuple[int, int], code: str, fresh: bool = False
) -> tuple[list[dict], dict[str, dict]]:
    """(jobs to run, cached results by part) for the page of a run writing to ``out_dir``."""
    jobs, cached = [], {}
    for part in parts():
        path = cache_path(out_dir, part, grid, code)
        shared = _shared(path)
        for src in (path, shared):
            if src is None or not src.is_file() or fresh:
                continue
            try:
                cached[part] = json.loads(src.read_text(encoding="utf-8"))
            except (OSError, ValueError):
                continue  # unreadable: computed again
            if src is shared:  # the run's folder holds what its page used
                _write(path, cached[part])
            break
        if part in cached:
            continue
        job = {"key": f"{ROLE}|{part}", "case": f"({ROLE})", "model": part, "role": ROLE}
        job["killable"] = False  # no per-pair time limit: an atlas is many solves
        jobs.append(job | {"call": run_job, "grid": grid, "cache": str(path)})
    return jobs, cached


def run_job(job: Mapping) -> dict:
    """Compute one part (in a pool worker or in-process), cache it; never raises."""
    from reports.render import mech_atlas, teaching
    from reports.run import timing

    out = {k: job[k] for k in ("key", "case", "model", "role")}
    timing.pin_blas()
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        if job["model"].startswith("mech-"):
            case = job["model"][len("mech-") :]
            data = {"mech": mech_atlas.teaching_data([case], mech_n_axis(job["grid"]))[case]}
        elif job["model"] == "extras":
            data: dict[str, Any] = {
                "cost": teaching.cost_scaling(),
                "shapes": teaching.shapes("cantilever-tip-load"),
            }
        else:
            n_mag, n_ang = job["grid"]
            at = atlas.compute(job["model"], atlas.MODELS, n_mag, n_ang)
            data = {"atlas": teaching.atlas_data(at), "per_state": per_state(at)}
    except Exception as exc:  # the report still appears; the page says what is missing
        return out | {"error": f"{type(exc).__name__}: {exc}"}
    finally:
        limits.trim_heap()
    data["wall_s"] = time.perf_counter() - t0
    data["cpu_s"] = time.process_time() - c0
    path = Path(job["cache"])
    for target in (path, _shared(path)):
        if target is not None:
            _write(target, data, f"{job['model']}-{job['grid'][0]}x{job['grid'][1]}-*")
    return out | {"data": data}


def _shared(path: Path) -> Path | None:
    """The same result's place in ``$FLEXBENCH_CACHE/teaching/`` (shared by every output
    folder: a run into a new folder reuses the atlases of the same code), or None when
    ``FLEXBENCH_NO_PAIR_CACHE`` is set."""
    import os

    from reports.verdicts.cost import cache_dir

    return None if os.environ.get("FLEXBENCH_NO_PAIR_CACHE") else cache_dir() / ROLE / path.name


def _write(path: Path, data: Mapping, stale: str | None = None) -> None:
    """Write one cached part (atomically), removing results of older code versions that
    match ``stale``; a cache that cannot be written is skipped (computed again next time)."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        for old in path.parent.glob(stale) if stale else ():
            old.unlink(missing_ok=True)
        tmp = path.with_suffix(f".tmp{id(data)}")
        tmp.write_text(json.dumps(data, allow_nan=False), encoding="utf-8")
        tmp.replace(path)
    except OSError:
        pass


def per_state(at: atlas.Atlas) -> dict[str, dict[str, float]]:
    """Per model: CPU s of its whole atlas, per state, and a single 20-step solve's CPU s
    divided by the per-state cost (how much cheaper a state is inside the batch)."""
    states = len(at.mags) * len(at.angles)
    out = {}
    for name, sec in at.seconds.items():
        each = sec / states
        single = at.single_s.get(name)
        ran = any(s != "not-applicable" for s in at.status[name])  # declining is no solve
        ratio = single / each if ran and single and each > 0 else None
        out[name] = {"atlas_cpu_s": sec, "per_state_s": each, "single_s": single, "ratio": ratio}
    return out


class TeachingJobs:
    """Collects the teaching jobs' results while the run solves (see module docstring)."""

    def __init__(self, out_dir: Path, grid: tuple[int, int], code: str):
        self.grid = grid
        self.jobs, self.results = plan_jobs(out_dir, grid, code)
        self.cached = sorted(self.results)
        self.errors: dict[str, str] = {}
        self.page_error: str | None = None

    def take(self, rec: Mapping) -> bool:
        """Keep a teaching job's result; False when ``rec`` is anything else."""
        if rec.get("role") != ROLE:
            return False
        if "data" in rec:
            self.results[rec["model"]] = rec["data"]
        else:
            self.errors[rec["model"]] = str(rec.get("error", "lost"))
        return True

    def write(self, payload: Mapping, out_dir: Path) -> Path | None:
        """Run, in this process, the jobs no pool ran (one worker, Dask, a lost job), then
        write ``teaching.html``; never raises (None, and ``self.page_error``, on failure)."""
        for job in self.jobs:
            if job["model"] not in self.results:
                self.errors.pop(job["model"], None)
                self.take(run_job(job))
        try:
            return write_page(self, payload, out_dir)
        except Exception as exc:  # the report itself must still appear
            self.page_error = f"{type(exc).__name__}: {exc}"
            warnings.warn(f"teaching page not written: {self.page_error}", stacklevel=1)
            (Path(out_dir) / "teaching.html").unlink(missing_ok=True)  # never a stale page
            return None


# -- the page --------------------------------------------------------------------------------
def advice(payload: Mapping, tolerances: Sequence[str] = TOLERANCES) -> list[dict]:
    """The recommender's verdict per (case, tolerance) over the models this run solved."""
    from reports.render import teaching
    from reports.render.teach_story import verdict_table
    from reports.verdicts.advice import from_records
    from reports.verdicts.recommendation import format_text

    out = []
    for name, case in payload["cases"].items():
        if case.get("sweep"):
            continue  # a point of a sweep: its parent's scene is one of many
        recs = [r for r in payload["results"] if r["case"] == name]
        for tol in tolerances:
            rec = from_records(case, recs, tol)
            if rec is None:
                continue
            curves = {c.model: c.profile for c in rec.candidates if c.profile}
            out.append(
                {
                    "case": name,
                    "tol": tol,
                    "recommended": rec.recommended,
                    "text": format_text(rec).rsplit("\n", 1)[0],  # no elapsed time line
                    "table": verdict_table(rec),
                    "profiles": {k: teaching._r(v, 3) for k, v in curves.items()},
                }
            )
    return out


def write_page(jobs: TeachingJobs, payload: Mapping, out_dir: Path) -> Path | None:
    """``OUT/teaching.html`` from the jobs' results and the run's advice (None when no atlas
    could be computed)."""
    from reports.render import teaching

    res = jobs.results
    fams = [f for f in atlas.FAMILIES if f in res]
    if not fams or "extras" not in res:
        return None
    n_mag, n_ang = jobs.grid
    source = "computed in this run"
    if jobs.cached:
        source = f"{len(jobs.cached)} of {len(parts())} reused from {CACHE_DIR}/ (same code)"
    data = {
        "families": teaching.family_cards(),
        "atlas": {f: res[f]["atlas"] for f in fams},
        "atlas_seconds": {f: round(res[f]["wall_s"], 2) for f in fams},
        "per_state": {f: res[f]["per_state"] for f in fams},
        "contours": list(atlas.CONTOURS),
        "cost": res["extras"]["cost"],
        "advice": advice(payload),
        "shapes": res["extras"]["shapes"],
        "mech_atlas": {p[len("mech-") :]: r["mech"] for p, r in res.items() if "mech" in r},
        "seconds": round(sum(p.get("cpu_s", 0.0) for p in res.values()), 1),
        "note": (
            f"Written by flexbench run: force and follower atlases on {n_mag} load magnitudes x "
            f"{n_ang} directions (flexbench teach: {GRID[0]} x {GRID[1]}), mechanism atlases "
            f"at {mech_n_axis(jobs.grid)} second-axis values; atlases and costs "
            f"{source}"
            "; the worked advice judges the models this run solved with the recommender's rules "
            "and pick, at the cost estimates flexbench recommend uses (flexbench recommend "
            "CASE also tries other N)." + (f" Missing: {jobs.errors}." if jobs.errors else "")
        ),
    }
    return teaching.write_page(data, Path(out_dir) / "teaching.html")
