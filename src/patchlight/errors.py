"""User-facing errors: one line, exit status 2, never a traceback."""


class PatchlightError(Exception):
    """Bad input or an impossible request. The message is one line for the user."""


class BakeInterrupted(Exception):
    """Raised when the user stops a bake with Ctrl-C; nothing partial is left behind."""
