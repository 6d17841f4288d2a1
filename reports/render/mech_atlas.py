"""Mechanism validity atlases (``reports.verdicts.atlas_mech``) in the report and the teaching page.

* ``figure(data, path)``: one PNG per case, a panel per model that solved any state (the
  others named in the title): log10 error over driver x second axis with a colour bar, the
  0.1 / 1 / 5 % contours, the region of our test of each published claim dashed and
  its failing states marked x.
* ``teaching_data(cases)``: the atlases for the teaching page (``render.teaching``), each with
  its figure as a data URI; ``save(mech, out_dir)`` writes them to ``mech_atlas.json`` and
  ``figures/mech-atlas-<case>.png`` so that the report shows them too.
* ``insert_blocks(blocks, out_dir)``: the report's mechanism case sections get their atlas
  (from ``mech_atlas.json`` when a teaching page was built into ``out_dir``).
"""

from __future__ import annotations

import base64
import io
import json
import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from reports.verdicts import atlas_mech, atlas_mech_axes

# the teaching page's mechanism atlases: a guide (load direction) and a driven bistable
# four-bar (member length), small enough for the default run
TEACH_CASES = ("das2d-ex2-parallelogram", "das2d-ex4-bistable-fourbar")
FILE = "mech_atlas.json"
CONTOUR_STYLES = (":", "-", "--")  # the 0.1 / 1 / 5 % contours


def _arr(x: Any) -> np.ndarray:
    return np.array([[np.nan if v is None else v for v in row] for row in x], dtype=float)


def figure(data: Mapping, dest: str | Path | None = None) -> bytes:
    """PNG bytes of one case's atlas (module docstring); also written to ``dest``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    models = [m for m, v in data["models"].items() if np.isfinite(_arr(v["error"])).any()]
    declined = [m for m in data["models"] if m not in models]
    cols = max(1, min(4, len(models)))
    rows = max(1, math.ceil(len(models) / cols))
    fig, axes = plt.subplots(
        rows,
        cols,
        figsize=(3.1 * cols + 0.9, 2.5 * rows + 0.9),
        dpi=80,
        squeeze=False,
        sharex=True,
        sharey=True,
        layout="constrained",
    )
    X, Y = np.meshgrid(np.array(data["drive"], float), np.array(data["values"], float))
    cmap = plt.get_cmap("viridis").with_extremes(bad="#bbbbbb")  # grey: failed (or no ref.)
    pcm = None
    for ax, name in zip(axes.ravel(), models):
        err = _arr(data["models"][name]["error"])
        pcm = ax.pcolormesh(X, Y, np.log10(np.clip(err, 1e-6, None)), vmin=-4, vmax=0, cmap=cmap)
        if np.isfinite(err).sum() > 3 and len(data["values"]) > 1:
            # told apart by line style (title), not by labels that pile up on dense contours
            ax.contour(
                X,
                Y,
                err,
                levels=list(data["contours"]),
                colors="w",
                linewidths=0.8,
                linestyles=CONTOUR_STYLES[: len(data["contours"])],
            )
        claims = [c for c in data["claims"] if c["model"] == name]
        for k, c in enumerate(claims):
            color = ["r", "orange"][k % 2]
            region = np.array(c["region"], float)
            if 0 < region.sum() < region.size:
                ax.contour(X, Y, region, levels=[0.5], colors=color, linestyles="--")
            bad = np.array(c["fails"], bool)
            ax.plot(X[bad], Y[bad], "x", color=color, ms=3)
        ax.set_title(name, fontsize=8)
        ax.tick_params(labelsize=6)
    for ax in axes.ravel()[len(models) :]:
        ax.axis("off")
    for k, ax in enumerate(axes.ravel()[: len(models)]):
        if k + cols >= len(models):  # nothing drawn below: this panel shows the x ticks
            ax.xaxis.set_tick_params(labelbottom=True)
    if pcm is not None:
        fig.colorbar(pcm, ax=axes, shrink=0.8, pad=0.01).set_label("log10 error_rel", fontsize=7)
    fig.supxlabel(data["drive_label"], fontsize=8)
    fig.supylabel(data["axis_label"], fontsize=8)
    levels = ", ".join(
        f"{v * 100:g} % {n}" for v, n in zip(data["contours"], ("dotted", "solid", "dashed"))
    )
    title = f"{data['case']}: log10 error vs fem-auto (white: {levels}; grey: the model fails)"
    if declined:
        title += "\nnot drawn (no state solved): " + ", ".join(declined)
    fig.suptitle(title, fontsize=9)
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    png = buf.getvalue()
    if dest is not None:
        Path(dest).parent.mkdir(parents=True, exist_ok=True)
        Path(dest).write_bytes(png)
    return png


def claim_lines(data: Mapping) -> list[str]:
    """One line per our test of a published claim: verdict, worst error, failing states,
    source, reading, and where the publication's own verdict is."""
    out = []
    for c in data["claims"]:
        worst = "-" if c["worst"] is None else f"{c['worst'] * 100:.3g} %"
        where = ""
        if c.get("worst_at"):
            where = ", worst failing state " + ", ".join(
                f"{k} {v:.4g}" for k, v in c["worst_at"].items()
            )
        out.append(
            f"{c['model']}: {c['label']}: {c['verdict'].upper()} (worst {worst} against our "
            f"threshold {c['accuracy'] * 100:.3g} %; {c['failing']} of {c['points']} states in "
            f"its range fail{where}). Source: {c['source']}. Reading: {c['reading']}."
            + (
                f" The publication's own verdict: flexbench claims --id {c['claim_id']}."
                if c.get("claim_id")
                else ""
            )
        )
    return out


def summary(data: Mapping) -> str:
    """The atlas's axes, batch size and cost in one paragraph."""
    n = len(data["values"]) * len(data["drive"])
    ratios = [m["cost_ratio"] for m in data["models"].values() if m.get("cost_ratio")]
    cost = f"; one atlas state costs {np.median(ratios):.3g} x a single solve (median)"
    return (
        f"Validity atlas: each model's error_rel against fem-auto (each output over its own "
        f"excursion along the driver path, the driven quantity relative to its largest value) "
        f"over {data['drive_label']} x "
        f"{data['axis_label']} ({n} states per model; why this axis: {data['axis_why']}); "
        f"one fem-auto and one path-following solve per model per axis value; "
        f"{data['wall_s']:.1f} s in all{cost if ratios else ''}. White contours 0.1 / 1 / 5 %; "
        "dashed: the range of our test of a published claim (the publication's own verdict: "
        "flexbench claims), x: states in it where our test fails."
    )


def teaching_data(
    names: Sequence[str] = TEACH_CASES,
    n_axis: int = 5,
    progress: Callable[[str], None] | None = None,
) -> dict[str, dict]:
    """case -> atlas JSON (``atlas_mech.as_json``) + ``png`` data URI, or ``{"none": why}``."""
    out: dict[str, dict] = {}
    for name in names:
        try:
            data = atlas_mech.as_json(atlas_mech.compute(name, n_axis=n_axis, progress=progress))
        except atlas_mech_axes.NoAtlas as exc:
            out[name] = {"case": name, "none": str(exc)}
            continue
        png = base64.b64encode(figure(data)).decode()
        out[name] = {**data, "png": "data:image/png;base64," + png}
    return out


def save(mech: Mapping[str, dict] | None, out_dir: str | Path) -> None:
    """Write ``mech_atlas.json`` (without the data URIs) and the figures into ``out_dir``."""
    if not mech:
        return
    out = Path(out_dir)
    slim = {}
    for name, data in mech.items():
        slim[name] = {k: v for k, v in data.items() if k != "png"}
        if "png" in data:
            png = base64.b64decode(data["png"].split(",", 1)[1])
            (out / "figures").mkdir(parents=True, exist_ok=True)
            (out / "figures" / f"mech-atlas-{name}.png").write_bytes(png)
    (out / FILE).write_text(json.dumps(slim, allow_nan=False), encoding="utf-8")


def insert_blocks(blocks: list, out_dir: str | Path) -> list:
    """``blocks`` with each atlased case's atlas at the end of its section."""
    path = Path(out_dir) / FILE
    if not path.is_file():
        return blocks
    from reports.render.frontpage import anchor

    mech = json.loads(path.read_text(encoding="utf-8"))
    out = list(blocks)
    for name, data in mech.items():
        at = next(
            (i for i, b in enumerate(out) if b[0] == "h2" and len(b) > 2 and b[2] == anchor(name)),
            None,
        )
        if at is None:
            continue
        end = next((i for i in range(at + 1, len(out)) if out[i][0] in ("h2", "/details")), None)
        end = len(out) if end is None else end + (out[end][0] == "/details")
        new: list = [("h3", f"Validity atlas over the driver range: {name}")]
        if "none" in data:
            new.append(("p", f"No atlas: {data['none']}."))
        else:
            new.append(("p", summary(data)))
            fig = Path(out_dir) / "figures" / f"mech-atlas-{name}.png"
            if fig.is_file():
                new.append(("img", f"figures/{fig.name}", f"{name}: validity atlas"))
            if data["claims"]:
                new.append(("ul", claim_lines(data)))
        out[end:end] = new
    return out
