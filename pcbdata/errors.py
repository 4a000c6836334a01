"""Errors that reach the user as one clear line (exit code 2), never as a traceback."""


class UserError(Exception):
    """Bad input: parameters, names, files. The message names what and why."""


class GenerationError(UserError):
    """A generator could not produce a board for the given parameters and seed."""


class ValidationError(Exception):
    """A generated board failed its check in KiCad."""
