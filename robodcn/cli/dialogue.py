"""The dialogue of the hands-on commands (calibrate, teach, servo set-id/set-baud): prompts
and notes on stderr, answers from stdin, one line each, so every dialogue can be scripted
(``printf '\\n\\ns\\n' | robodcn calibrate ...``)."""

from __future__ import annotations

import sys


def say(text: str) -> None:
    """One line for the user on stderr (stdout stays the command's output)."""
    print(text, file=sys.stderr, flush=True)


def stdin_prompt(message: str) -> str:
    """Show ``message`` on stderr and read one line from stdin (EOFError at its end)."""
    sys.stderr.write(f"{message}: ")
    sys.stderr.flush()
    line = sys.stdin.readline()
    if not line:
        sys.stderr.write("\n")
        raise EOFError
    return line.rstrip("\r\n")


def confirm(question: str, *, yes: bool = False) -> bool:
    """True when ``yes`` (``--yes``) or the user answers y/yes; end of input is no."""
    if yes:
        return True
    try:
        return stdin_prompt(f"{question} [y/N]").strip().lower() in ("y", "yes")
    except EOFError:
        return False


__all__ = ["confirm", "say", "stdin_prompt"]
