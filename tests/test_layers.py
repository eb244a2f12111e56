"""The package's import structure (docs/architecture.md): the layer contract of pyproject.toml
(import-linter) and no import cycle between modules, lazy imports inside functions included."""

from __future__ import annotations

import sys
from pathlib import Path

import grimp
from importlinter import cli

REPO = Path(__file__).resolve().parents[1]


def test_import_layers_are_kept():
    """app → evaluate → plots → {track | stages | sim} → chain → {io | acoustics} →
    {dsp | geo} → {config | data} → errors: no import goes up, no sibling imports another."""
    assert cli.lint_imports(config_filename=str(REPO / "pyproject.toml"), no_cache=True,
                            no_logo=True) == 0


def _cycles(graph: grimp.ImportGraph) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    sys.setrecursionlimit(max(10_000, sys.getrecursionlimit()))
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.find_modules_directly_imported_by(v):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for m in sorted(graph.modules):
        if m not in index:
            visit(m)
    return out


def test_no_import_cycles():
    graph = grimp.build_graph("arrayproc", cache_dir=None)  # lazy imports included
    assert _cycles(graph) == []


def test_cycle_finder_finds_a_cycle():
    g = grimp.ImportGraph()
    for m in ("p", "p.a", "p.b", "p.c"):
        g.add_module(m)
    g.add_import(importer="p.a", imported="p.b")
    g.add_import(importer="p.b", imported="p.a")
    g.add_import(importer="p.c", imported="p.a")
    assert _cycles(g) == [["p.a", "p.b"]]
