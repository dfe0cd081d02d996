"""Error types that the command line turns into a one-line message and exit code 2."""


class InputError(Exception):
    """Bad usage or bad input: says what is wrong and where (exit code 2)."""


class StartrackWarning(UserWarning):
    """Something the user should know, the run going on (the command line prints it as
    one ``startrack: warning:`` line)."""

