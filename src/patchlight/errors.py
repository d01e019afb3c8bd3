"""User-facing errors: one line, exit status 2, never a traceback."""


class PatchlightError(Exception):
    """Bad input or an impossible request. The message is one line for the user."""

