"""Errors a user can cause. The command line turns them into one line and exit status 2."""


class ArrayprocError(Exception):
    """A problem with the user's input (file, configuration, arguments), not a bug.

    The message names the offending file or key and reads as one line.
    """


class ConfigError(ArrayprocError):
    """A chain, scenario or tracker configuration is invalid."""


class FormatError(ArrayprocError):
    """A file is missing, unreadable or does not follow the expected format."""


class Interrupted(BaseException):  # noqa: N818 - like KeyboardInterrupt, not an Exception
    """The run was stopped by a signal (SIGINT, SIGTERM, SIGHUP).

    A :class:`BaseException`, so ``except Exception`` in library code does not swallow it. The
    command line exits with status 128 + ``signum`` (130, 143, 129).
    """

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = int(signum)

    def __str__(self) -> str:
        import signal
        try:
            name = signal.Signals(self.signum).name
        except ValueError:
            name = f"signal {self.signum}"
        return f"interrupted by {name}"
