"""Error types that the command line turns into a one-line message and exit code 2."""


class InputError(Exception):
    """Bad usage or bad input: says what is wrong and where (exit code 2)."""


class InputFileNotFoundError(InputError, FileNotFoundError):
    """An input file that does not exist: an :class:`InputError` for the command line, a
    ``FileNotFoundError`` for Python callers."""


class InputValueError(InputError, ValueError):
    """A bad value given to the Python API: an :class:`InputError` that is also a
    ``ValueError``, as Python callers expect (:func:`as_builtin`)."""


def as_builtin(exc: InputError) -> InputError:
    """``exc`` as the API raises it: already a built-in subclass, or the same message as
    an :class:`InputValueError`."""
    if isinstance(exc, ValueError | OSError | TypeError):
        return exc
    return InputValueError(*exc.args)


class StartrackWarning(UserWarning):
    """Something the user should know, the run going on (the command line prints it as
    one ``startrack: warning:`` line)."""

