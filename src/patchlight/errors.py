"""User-facing errors: one line, exit status 2, never a traceback."""


class PatchlightError(Exception):
    """Bad input or an impossible request. The message is one line for the user."""



class SettingError(PatchlightError):
    """A setting outside what its field accepts. Names the field (`field`, `value`, `problem`);
    the command line names the flag that set it instead (cli/main.py)."""

    def __init__(self, field: str, value, problem: str):
        super().__init__(f"{field}: {value!r} {problem}")
        self.field, self.value, self.problem = field, value, problem
