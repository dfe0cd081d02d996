"""Error types that the command line turns into a one-line message and exit code 2."""


class InputError(Exception):
    """Bad usage or bad input: says what is wrong and where (exit code 2)."""


class StartrackWarning(UserWarning):
    """Something the user should know, the run going on (the command line prints it as
    one ``startrack: warning:`` line)."""




def __getattr__(name: str):
    """``check_number`` from its old place: it lives in startrack.validate (one layer for
    every source), imported on use since validate imports the classes above."""
    if name == "check_number":
        from startrack.validate import check_number

        return check_number
    raise AttributeError(f"module 'startrack.errors' has no attribute {name!r}")
