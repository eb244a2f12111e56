"""Screenshots of each section of the report of the demo products, in headless chromium.

    arrayproc demo -o demo_out
    python scripts/report_screenshots.py demo_out -o docs/figures/report

Builds ``demo_out/report.html`` from the demo's products (the towed passive run with its
tracks and, made here when missing, its bearings-only TMA; the active run; the field
recording's TDOA localisation when the demo had it), opens it in chromium
(:mod:`arrayproc.plots.interactive.browser`), clicks a beam on the BTR so that the LOFAR
shows it, and writes one PNG per section (colours reduced to a 256-colour palette to keep
the files small).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from arrayproc.app import commands
from arrayproc.app.report import report
from arrayproc.data import data_path
from arrayproc.plots.interactive.browser import browser_missing, data_point, open_page

#: Demo products the report shows, in page order (those present are used).
DEMO_FILES = ("towed_passive_products.h5", "towed_passive_tracks.h5", "towed_passive_tma.h5",
              "active_products.h5", "xav_localise.h5")
#: The BTR beam (cone angle, deg) clicked before the screenshots: the merchant's tonals.
CLICK_CONE_DEG = 120.0


def demo_report(demo: Path) -> Path:
    """The report of the demo products (the TMA made first when missing)."""
    tma = demo / "towed_passive_tma.h5"
    if not tma.exists() and (demo / "towed_passive_products.h5").exists():
        commands.tma(str(demo / "towed_passive_products.h5"),
                     str(data_path() / "tma" / "bearings.toml"), str(tma))
    files = [str(demo / f) for f in DEMO_FILES if (demo / f).exists()]
    if not files:
        raise SystemExit(f"{demo}: no demo products (run: arrayproc demo -o {demo})")
    out = demo / "report.html"
    r = report(files, out, title="arrayproc report: the demo's products")
    print(f"{out}: {r['bytes'] / 1e6:.1f} MB, sections {', '.join(r['sections'])}")
    return out


def _small_png(path: Path) -> None:
    """Rewrite a PNG with a 256-colour palette."""
    from PIL import Image
    with Image.open(path) as im:
        im.convert("RGB").quantize(colors=256, method=Image.Quantize.MEDIANCUT).save(
            path, optimize=True)


def screenshots(html: Path, outdir: Path) -> list[Path]:
    """One PNG per section of the page, after a click on the BTR's CLICK_CONE_DEG beam."""
    outdir.mkdir(parents=True, exist_ok=True)
    made = []
    with open_page(html, width=1200, height=1000) as (page, errors):
        if page.locator(".section-passive").count():
            y = page.evaluate("() => { const r = Bokeh.documents[0].get_model_by_name('btr')"
                              ".y_range; return 0.5 * (r.start + r.end); }")
            page.mouse.click(*data_point(page, "btr", CLICK_CONE_DEG, y))
            page.mouse.move(1, 1)  # no tooltip left over the plots
            page.wait_for_timeout(500)
        for css in ("section-summary", "section-passive", "section-bearings",
                    "section-tracks", "section-active", "section-tdoa"):
            loc = page.locator(f".{css}")
            if not loc.count():
                continue
            out = outdir / f"{css.removeprefix('section-')}.png"
            loc.first.scroll_into_view_if_needed()
            page.wait_for_timeout(300)
            loc.first.screenshot(path=str(out))
            _small_png(out)
            made.append(out)
            print(f"{out}: {out.stat().st_size / 1e3:.0f} kB")
    if errors:
        raise SystemExit(f"{html}: the browser reported: {errors}")
    return made


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("demo", type=Path, help="the demo's output directory")
    p.add_argument("-o", "--output", type=Path, default=Path("docs/figures/report"),
                   help="folder of the screenshots")
    a = p.parse_args(argv)
    why = browser_missing()
    if why:
        print(f"report_screenshots: {why}", file=sys.stderr)
        return 2
    screenshots(demo_report(a.demo), a.output)
    return 0


if __name__ == "__main__":
    sys.exit(main())
