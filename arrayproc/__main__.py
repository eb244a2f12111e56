"""``python -m arrayproc``: the command line."""

from arrayproc.app import early

early.install()  # first: a stop signal during the imports below is handled as later ones

import sys  # noqa: E402

from arrayproc.app.cli import main  # noqa: E402

sys.exit(main())
