"""Writing to standard output when the reader may go away (``robodcn plan … | head``), and
files a hand's work went into (taught poses, a calibration), which must never be lost."""

from __future__ import annotations

import os
import sys
from pathlib import Path

from robodcn._files import write_or_rescue
from robodcn.errors import FileWriteError


def emit(text: str) -> bool:
    """Write ``text`` to stdout; False (and stdout silenced) if the reader closed the pipe.

    A closed pipe is the reader's choice, not an error: the command carries on and exits
    with its own code, and nothing more is written (no BrokenPipeError at exit either).
    """
    try:
        sys.stdout.write(text)
        sys.stdout.flush()
        return True
    except BrokenPipeError:
        silence_stdout()
        return False


def save_work(path: str | os.PathLike[str], text: str, *, what: str) -> Path:
    """Write ``text`` (``--out``) whole (:func:`robodcn._files.write_or_rescue`); when it
    cannot be written anywhere, not even in the current or the temporary directory, the
    text goes to standard output so the user still has it.

    Raises
    ------
    FileWriteError
        ``path`` was not written; the message says where ``what`` is instead.
    """
    try:
        return write_or_rescue(path, text, field="--out", what=what)
    except FileWriteError as exc:
        if exc.saved_to is not None or not emit(text):
            raise
        raise FileWriteError(f"{exc.message}; it is printed on standard output",
                             path=exc.path, strerror=exc.strerror, errno=exc.errno,
                             field=exc.field) from None


def silence_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's final flush cannot fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):  # not a real file (captured in tests)
        pass


__all__ = ["emit", "save_work", "silence_stdout"]
