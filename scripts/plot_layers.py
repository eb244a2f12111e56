"""Draw the package's import layers (docs/figures/layers.png) from the import-linter contract
in pyproject.toml and the imports grimp finds (every import statement, lazy ones included).

Each row is a layer, top to bottom as the contract lists them; each box a package with its
module count; an arrow from one package to another is labelled with the number of
module-to-module imports between them.

    .venv/bin/python scripts/plot_layers.py [-o docs/figures/layers.png]
"""

from __future__ import annotations

import argparse
import collections
from pathlib import Path

import grimp
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import FancyArrowPatch, FancyBboxPatch  # noqa: E402

from arrayproc.config import read_toml  # noqa: E402

REPO = Path(__file__).resolve().parents[1]


def layers() -> list[list[str]]:
    cfg = read_toml(REPO / "pyproject.toml", "project")[0]
    contract = cfg["tool"]["importlinter"]["contracts"][0]
    return [[p.strip() for p in row.split("|")] for row in contract["layers"]]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", default=str(REPO / "docs" / "figures" / "layers.png"))
    out = Path(ap.parse_args().output)
    rows = layers()
    graph = grimp.build_graph("arrayproc", cache_dir=None)
    pkgs = [p for row in rows for p in row]

    def owner(mod: str) -> str | None:
        for p in sorted(pkgs, key=len, reverse=True):
            if mod == p or mod.startswith(p + "."):
                return p
        return None

    n_mod = collections.Counter(owner(m) for m in graph.modules)
    edges: collections.Counter = collections.Counter()
    for m in graph.modules:
        a = owner(m)
        for n in graph.find_modules_directly_imported_by(m):
            b = owner(n)
            if a and b and a != b:
                edges[(a, b)] += 1

    fig, ax = plt.subplots(figsize=(11, 8.5))
    pos: dict[str, tuple[float, float]] = {}
    w, h = 2.1, 0.5
    for i, row in enumerate(rows):
        y = -i * 1.0
        xs = [(j - (len(row) - 1) / 2) * 2.8 for j in range(len(row))]
        for x, p in zip(xs, row):
            pos[p] = (x, y)
            ax.add_patch(FancyBboxPatch((x - w / 2, y - h / 2), w, h,
                                        boxstyle="round,pad=0.05", fc="#dbe8f5", ec="#1f4e79",
                                        zorder=3))
            ax.text(x, y + 0.06, p.removeprefix("arrayproc."), ha="center", va="center",
                    fontsize=11, weight="bold", zorder=4)
            ax.text(x, y - 0.15, f"{n_mod[p]} modules", ha="center", va="center", fontsize=8,
                    zorder=4)
    for (a, b), k in edges.items():
        (xa, ya), (xb, yb) = pos[a], pos[b]
        arr = FancyArrowPatch((xa, ya - h / 2), (xb, yb + h / 2), arrowstyle="-|>",
                              mutation_scale=9, lw=0.6 + 0.25 * min(k, 12) ** 0.5,
                              color="#555555", alpha=0.6,
                              connectionstyle="arc3,rad=0.08", zorder=1)
        ax.add_patch(arr)
        ax.text(xa + 0.58 * (xb - xa), ya + 0.58 * (yb - ya) - h / 4, str(k), fontsize=6,
                color="#444444")
    ax.set_xlim(-5.5, 5.5)
    ax.set_ylim(-len(rows) + 0.3, 0.7)
    ax.axis("off")
    ax.set_title("arrayproc import layers: imports only go down (arrow labels: module imports)",
                 fontsize=11)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"{out}: {len(pkgs)} packages, {sum(edges.values())} cross-package imports")


if __name__ == "__main__":
    main()
