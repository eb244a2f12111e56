"""Errors a user can cause. The command line turns them into one line and an exit status:
2 for a bad input, configuration or argument; :data:`EXIT_WRITE` (74) for an output that
could not be written (:class:`OutputWriteError`: disk full, quota, I/O error, read-only file
system); :data:`EXIT_MEMORY` (75) for a run stopped at the memory limit
(:class:`MemoryLimitError`). ``docs/reliability.md`` lists every status.
"""

#: Exit status of a bad input (file, configuration, argument).
EXIT_USAGE = 2
#: Exit status of an output that could not be written (sysexits.h ``EX_IOERR``).
EXIT_WRITE = 74
#: Exit status of a run stopped at its memory limit (sysexits.h ``EX_TEMPFAIL``: retry with
#: more memory or smaller parameters).
EXIT_MEMORY = 75


class ArrayprocError(Exception):
    """A problem with the user's input (file, configuration, arguments), not a bug.

    The message names the offending file or key and reads as one line.
    """

    #: The command line's exit status for this error.
    exit_status = EXIT_USAGE


class ConfigError(ArrayprocError):
    """A chain, scenario or tracker configuration is invalid."""


class FormatError(ArrayprocError):
    """A file is missing, unreadable or does not follow the expected format."""


class OutputWriteError(ArrayprocError):
    """An output could not be written: the disk is full (ENOSPC), a quota is exceeded
    (EDQUOT), an I/O error (EIO), a read-only file system (EROFS), ... Nothing was left: the
    temporary file was closed and removed. Exit status :data:`EXIT_WRITE`.

    Parameters
    ----------
    output : str
        The output the command was writing (named in the message).
    err : OSError
        The failed system call's error.
    """

    exit_status = EXIT_WRITE

    def __init__(self, output: str, err: OSError) -> None:
        import errno as _errno
        import os as _os
        self.output = str(output)
        self.errno = err.errno
        code = _errno.errorcode.get(err.errno or 0, "")
        reason = _os.strerror(err.errno) if err.errno else str(err)
        hint = HINTS.get(code, "")
        super().__init__(f"{output}: cannot write the output: {reason}"
                         f"{f' ({code})' if code else ''}; nothing was written{hint}")


#: What to do about a write failure, by errno name.
HINTS = {
    "ENOSPC": " (free space in the output's folder or give another -o)",
    "EDQUOT": " (the disk quota is exceeded: free space or give another -o)",
    "EROFS": " (the file system is read-only: give another -o)",
    "EIO": " (the storage reported an I/O error: check the disk)",
    "EFBIG": " (the file is larger than the file system allows: give another -o)",
}


class MemoryLimitError(ArrayprocError):
    """A run reached its memory limit (``--max-memory`` or the process's own limit) and was
    stopped cleanly; the message names the stage or tracker. Exit status :data:`EXIT_MEMORY`."""

    exit_status = EXIT_MEMORY


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
