"""Write docs/api.md, the API reference generated from the curated public names.

    python scripts/make_api_docs.py            # rewrite docs/api.md
    python scripts/make_api_docs.py --check    # exit 1 when docs/api.md is out of date

The text comes from :func:`arrayproc.app.api_docs.markdown`; tests/test_api_docs.py checks that
the committed file equals it.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from arrayproc.app.api_docs import markdown

OUT = Path(__file__).resolve().parents[1] / "docs" / "api.md"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="only compare, exit 1 when it differs")
    ap.add_argument("-o", "--output", type=Path, default=OUT, help="file to write (docs/api.md)")
    args = ap.parse_args(argv)
    text = markdown()
    if args.check:
        same = args.output.exists() and args.output.read_text() == text
        print(f"{args.output}: {'up to date' if same else 'out of date'}")
        return 0 if same else 1
    args.output.write_text(text)
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
