"""Errors a user can cause: the CLI turns them into one line on stderr and a non-zero exit."""


class HadimError(Exception):
    """A user-facing error: bad input, unknown run, unusable store. Never a bug."""

    exit_code = 2


class ConfigError(HadimError):
    """A configuration file or override is invalid (unknown key, wrong type, impossible value)."""


class ActionError(HadimError, ValueError):
    """A primitive action was refused by the world (wrong shape, out of range, not finite)."""
