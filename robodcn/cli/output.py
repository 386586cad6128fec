"""Writing to standard output when the reader may go away (``robodcn plan … | head``)."""

from __future__ import annotations

import os
import sys


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


def silence_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's final flush cannot fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):  # not a real file (captured in tests)
        pass


__all__ = ["emit", "silence_stdout"]
