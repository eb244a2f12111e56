"""Errors a user can cause. The command line turns them into one line and exit status 2."""


class ArrayprocError(Exception):
    """A problem with the user's input (file, configuration, arguments), not a bug.

    The message names the offending file or key and reads as one line.
    """


class ConfigError(ArrayprocError):
    """A chain, scenario or tracker configuration is invalid."""


class FormatError(ArrayprocError):
    """A file is missing, unreadable or does not follow the expected format."""
