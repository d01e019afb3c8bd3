"""User-facing errors: one line, exit status 2, never a traceback."""


class PatchlightError(Exception):
    """Bad input or an impossible request. The message is one line for the user. It names
    settings by their field names, in backquotes (`texels_per_unit`); the command line names
    the flags that set them instead (cli/parser.py `user_line`)."""


class PatchlightWarning(UserWarning):
    """Something the user should know that does not stop the work (the command line prints
    it as one line, `patchlight: warning: ...`; other libraries' warnings it hides)."""


class SettingError(PatchlightError):
    """A setting outside what its field accepts. Names the field (`field`, `value`, `problem`);
    the command line names the flag that set it instead."""

    def __init__(self, field: str, value, problem: str):
        super().__init__(f"{field}: {value!r} {problem}")
        self.field, self.value, self.problem = field, value, problem
