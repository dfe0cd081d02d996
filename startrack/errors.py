"""Error types that the command line turns into a one-line message and exit code 2."""


# Control characters as Python writes them in a string literal ("\n" -> "\\n"): a file
# name may hold a newline, and an error or warning naming it must stay one line.
_ESCAPES = {c: repr(chr(c))[1:-1] for c in [*range(32), 127]}


def one_line(text: str) -> str:
    """``text`` with its control characters (newline, tab, ...) escaped."""
    return text.translate(_ESCAPES)


class InputError(Exception):
    """Bad usage or bad input: says what is wrong and where (exit code 2). Its message
    is one line whatever the names it quotes (:func:`one_line`)."""

    def __str__(self) -> str:
        return one_line(super().__str__())


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

    def __str__(self) -> str:
        return one_line(super().__str__())

__all__ = [
    "InputError", "InputFileNotFoundError", "InputValueError", "StartrackWarning", "as_builtin",
    "one_line",
]
