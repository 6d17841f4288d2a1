"""The house plan as a test: the project's import graph has no circle and no arrow against
the import rules of ``../shared/DESIGN.md`` ("A module map").

The graph is read from the source with :mod:`ast` (nothing is imported), so an import
inside a function counts like one at the top of a module: a lazy import only hides a
circle from the interpreter, not from a reader.  Imports under ``if TYPE_CHECKING:`` do not
count: they name a type for an annotation and never run.

The rules, one room at a time (a room is a top-level package):

- ``cases`` imports nothing of ours;
- ``reduced_models`` imports ``cases`` (and itself);
- ``fem_reference`` imports ``cases`` and, from ``reduced_models``, only ``reduced_models.base``
  (the model protocol and ``Solution``: the reference shares no numerics with what it judges);
- ``reports`` imports all three;
- nothing imports ``reports`` (``tests`` may import anything).

Inside ``reports`` (its rooms: ``run``, ``verdicts``, ``render``, ``bench``; ``api`` and ``cli``
on top), the command line is the top floor and the benchmarks stand aside:

- only ``reports.cli`` imports ``reports.cli`` or ``reports.cli_args``;
- nothing but ``reports.bench`` imports ``reports.bench``;
- ``reports.verdicts`` (what a solution is worth) imports no page code (``reports.render``).
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ROOMS = ("cases", "reduced_models", "fem_reference", "reports")

# Which rooms each room may import (besides itself); reduced_models.base is the one door
# from fem_reference into reduced_models.
ALLOWED = {
    "cases": set(),
    "reduced_models": {"cases"},
    "fem_reference": {"cases"},
    "reports": {"cases", "reduced_models", "fem_reference"},
}
DOORS = {("fem_reference", "reduced_models.base")}

# Inside reports: (importing room prefix, imported prefix) arrows that must not exist; an
# importer inside the imported prefix itself is allowed (a room imports its own modules).
REPORTS_FORBIDDEN = (
    ("reports", "reports.cli"),  # covers reports.cli_args too
    ("reports", "reports.bench"),
    ("reports.verdicts", "reports.render"),
)


def _module_name(path: Path) -> str:
    """Dotted module name of a source file under ROOT (a package is its ``__init__``)."""
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    """Every module of the four rooms, by dotted name."""
    found = {}
    for room in ROOMS:
        for path in sorted((ROOT / room).rglob("*.py")):
            found[_module_name(path)] = path
    return found


def _resolve(name: str, modules: dict[str, Path]) -> str | None:
    """The project module a dotted import name refers to (the longest known prefix)."""
    while name:
        if name in modules:
            return name
        name = name.rpartition(".")[0]
    return None


def _imports(module: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """Project modules that ``module`` imports anywhere in its body (functions included).

    ``from pkg import name`` counts as an arrow to ``pkg.name`` when that is a module,
    else to ``pkg``.
    """
    is_package = path.name == "__init__.py"
    package = module if is_package else module.rpartition(".")[0]
    targets = set()
    tree = ast.parse(path.read_text(), filename=str(path))
    type_only = {
        id(inner)
        for node in ast.walk(tree)
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)
        for stmt in node.body
        for inner in ast.walk(stmt)
    }
    for node in ast.walk(tree):
        if id(node) in type_only:
            continue
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                stem = ".".join(base + ([node.module] if node.module else []))
            else:
                stem = node.module or ""
            names = [
                f"{stem}.{alias.name}" if f"{stem}.{alias.name}" in modules else stem
                for alias in node.names
            ]
        else:
            continue
        for name in names:
            target = _resolve(name, modules)
            if target is not None and target != module:
                targets.add(target)
    return targets


def import_graph() -> dict[str, set[str]]:
    """The project's import graph: module -> the project modules it imports."""
    modules = _modules()
    return {name: _imports(name, path, modules) for name, path in modules.items()}


def _strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components with more than one module (the circles)."""
    index, low, stack, on_stack, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def _package_edge(src: str, dst: str) -> bool:
    """An arrow from a package's ``__init__`` into its own subtree: the package re-exporting
    its public names, which Python resolves whatever order the submodules load in."""
    return dst.startswith(src + ".")


def circles() -> list[list[str]]:
    """The import circles between modules (a package's re-exports of its own submodules
    aside)."""
    graph = import_graph()
    pruned = {v: {w for w in ws if not _package_edge(v, w)} for v, ws in graph.items()}
    return _strongly_connected(pruned)


def wrong_arrows() -> list[str]:
    """Arrows from one room into another that the import rules forbid."""
    bad = []
    for src, targets in import_graph().items():
        room = src.split(".")[0]
        for dst in sorted(targets):
            other = dst.split(".")[0]
            if other == room or other in ALLOWED[room]:
                continue
            if (room, dst) in DOORS:
                continue
            bad.append(f"{src} -> {dst}")
    return bad


def _inside(name: str, prefix: str) -> bool:
    """``name`` is the module or package ``prefix`` or lies under it (``reports.cli`` also
    stands for ``reports.cli_args``: a prefix ending in a module name covers its siblings
    that extend the name)."""
    return name == prefix or name.startswith(prefix + ".") or name.startswith(prefix + "_")


def wrong_floors(graph: dict[str, set[str]] | None = None) -> list[str]:
    """Arrows inside ``reports`` against ``REPORTS_FORBIDDEN``."""
    graph = import_graph() if graph is None else graph
    bad = []
    for src, targets in graph.items():
        for dst in sorted(targets):
            for importer, imported in REPORTS_FORBIDDEN:
                if _inside(src, importer) and _inside(dst, imported):
                    if not _inside(src, imported):
                        bad.append(f"{src} -> {dst}")
    return sorted(bad)


def test_graph_is_read():
    """The reader sees the arrows it should (so an empty answer below means something)."""
    graph = import_graph()
    assert "cases.load" in graph
    assert "cases.schema" in graph["cases.load"]
    assert any(dst.startswith("cases") for dst in graph["reports.run.runner"])


def test_no_import_circle():
    found = circles()
    assert not found, "import circles:\n" + "\n".join(" <-> ".join(c) for c in found)


def test_no_arrow_against_the_rules():
    bad = wrong_arrows()
    assert not bad, "imports against DESIGN.md's rules:\n" + "\n".join(bad)


def test_no_arrow_against_the_floors_of_reports():
    bad = wrong_floors()
    assert not bad, "imports against the floors of reports:\n" + "\n".join(bad)


def test_planted_circle_and_wrong_arrow_are_seen():
    """The checks can fail: a planted circle and a planted upward arrow are reported."""
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _strongly_connected(graph) == [["a", "b", "c"]]
    assert _package_edge("reports.render", "reports.render.html")
    assert not _package_edge("reports.render.scenes", "reports.render")
    assert not _package_edge("reports.render", "reports.run.runner")
    planted = {
        "reports.run.runner": {"reports.cli_args"},
        "reports.verdicts.atlas": {"reports.render.figures"},
        "reports.render.html": {"reports.bench.speed"},
        "reports.cli": {"reports.cli_args", "reports.bench.speed"},
        "reports.bench.speed": {"reports.bench.measure"},
    }
    assert wrong_floors(planted) == [
        "reports.cli -> reports.bench.speed",
        "reports.render.html -> reports.bench.speed",
        "reports.run.runner -> reports.cli_args",
        "reports.verdicts.atlas -> reports.render.figures",
    ]


if __name__ == "__main__":
    for c in circles():
        print("circle:", " <-> ".join(c))
    for a in wrong_arrows():
        print("wrong arrow:", a)
