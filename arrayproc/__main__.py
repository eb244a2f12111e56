"""``python -m arrayproc``: the command line."""

from arrayproc.app import early

early.install()  # first: a stop signal during the imports below is handled as later ones

from arrayproc.app.cli import command  # noqa: E402

command()
