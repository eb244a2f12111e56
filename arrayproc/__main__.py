"""``python -m arrayproc``: the command line."""

import sys

from arrayproc.app.cli import main

sys.exit(main())
