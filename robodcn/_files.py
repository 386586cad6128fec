"""Every file robodcn writes, written whole or not at all.

:func:`replace_file` writes to a temporary file beside the target (same directory, so the
same file system), flushes and fsyncs it, gives it the old file's mode, then renames it over
the target (``os.replace``, atomic on POSIX) and fsyncs the directory. A reader, a crash
or a ``kill -9`` at any moment sees the old file or the new one, never a truncated mix; a
failed write (disk full, permission, an error in the writer) removes the temporary file,
keeps the old one and raises :class:`~robodcn.errors.FileWriteError` naming the path and
the operating system's reason. The pattern is the one in Linux's rename(2) ("If newpath
already exists, it will be atomically replaced") and SQLite's "atomic commit" notes: write,
fsync the data, rename, fsync the directory.

:func:`write_or_rescue` is for content a hand made (taught poses, a calibration): when the
file cannot be written it saves the content under a timestamped name in the current
directory, else the temporary directory, and the error says where.

A path that exists and is no regular file (``/dev/stdout``, a FIFO) is written to in place:
there is nothing to keep, and renaming over it would replace the device node.

A ``kill -9`` between the temporary file's creation and the rename leaves the temporary
file (``.NAME.<pid>.<random>.tmp``) beside the target; the target itself is intact.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import stat
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO

from robodcn.errors import FileWriteError

#: The mode a new file gets before the umask (as ``open(path, "w")`` would).
NEW_FILE_MODE = 0o666


def write_file(path: str | os.PathLike[str], data: str | bytes, *, field: str | None = None,
               encoding: str = "utf-8") -> Path:
    """Write ``data`` (text in ``encoding``, or bytes) to ``path`` atomically
    (:func:`replace_file`); returns the path written."""
    raw = data.encode(encoding) if isinstance(data, str) else bytes(data)
    return replace_file(path, lambda out: out.write(raw), field=field)


def replace_file(path: str | os.PathLike[str], write: Callable[[BinaryIO], object], *,
                 field: str | None = None) -> Path:
    """Call ``write(out)`` on a temporary binary file beside ``path``, then make it ``path``.

    Parameters
    ----------
    path
        The file to create or replace. A symbolic link is followed: its target is replaced
        and the link kept.
    write
        Writes the whole content to ``out`` (e.g. ``fig.savefig(out, format="png")``).
    field
        The option or field that named the path (``"--out"``), for the error.

    Returns
    -------
    Path
        ``path`` as given.

    Raises
    ------
    FileWriteError
        When creating, writing, syncing or renaming fails (``.path``, ``.strerror``,
        ``.errno``); the old file, if any, is unchanged and no temporary file is left.
        An exception of ``write`` other than OSError is re-raised as it is, after the same
        clean-up.
    """
    given = Path(path)
    target = Path(os.path.realpath(given))
    try:
        old = os.stat(target)
    except OSError:                     # none (or its directory is gone): open says why
        old = None
    if old is not None and not stat.S_ISREG(old.st_mode):
        _write_in_place(given, target, write, field)
        return given
    old_mode = None if old is None else stat.S_IMODE(old.st_mode)
    tmp = target.with_name(f".{target.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0),
                     NEW_FILE_MODE)
    except OSError as exc:
        raise _error(given, exc, field, existed=old_mode is not None) from None
    try:
        with os.fdopen(fd, "wb") as out:
            write(out)
            out.flush()
            if old_mode is not None:
                os.fchmod(out.fileno(), old_mode)
            os.fsync(out.fileno())
        os.replace(tmp, target)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(exc, OSError):
            raise _error(given, exc, field, existed=old_mode is not None) from None
        raise
    _sync_directory(target.parent)
    return given


def _write_in_place(given: Path, target: Path, write: Callable[[BinaryIO], object],
                    field: str | None) -> None:
    """A target that is no regular file (``/dev/stdout``, a FIFO, a terminal) is written to
    as it is: it has no old content to keep, and a rename over it would replace the device
    node itself with a file."""
    try:
        with open(target, "wb") as out:
            write(out)
    except OSError as exc:
        reason = exc.strerror or str(exc)
        where = f"{field} {given}" if field else str(given)
        raise FileWriteError(f"{where}: cannot write ({reason})", path=str(given),
                             strerror=reason, errno=exc.errno, field=field) from None


def write_or_rescue(path: str | os.PathLike[str], data: str, *, field: str | None = None,
                    what: str = "the content") -> Path:
    """:func:`write_file`, and when that fails save ``data`` elsewhere so it is not lost.

    The rescue file is ``<stem>-unsaved-<YYYYmmdd-HHMMSS><suffix>`` in the current
    directory, else in :func:`tempfile.gettempdir`.

    Raises
    ------
    FileWriteError
        ``path`` could not be written; the message says where ``what`` was saved
        (``.saved_to``; None when neither directory could take it: the caller then has
        ``data`` to show).
    """
    try:
        return write_file(path, data, field=field)
    except FileWriteError as exc:
        failed = exc
    saved = rescue(path, data)
    if isinstance(saved, Path):
        raise FileWriteError(f"{failed.message}; {what} saved in {saved}", path=failed.path,
                             strerror=failed.strerror, errno=failed.errno, field=field,
                             saved_to=str(saved)) from None
    raise FileWriteError(f"{failed.message}; {what} could not be saved elsewhere either "
                         f"({saved})", path=failed.path, strerror=failed.strerror,
                         errno=failed.errno, field=field) from None


def rescue(path: str | os.PathLike[str], data: str) -> Path | str:
    """Save ``data``, meant for ``path``, as ``<stem>-unsaved-<YYYYmmdd-HHMMSS><suffix>`` in
    the current directory, else in :func:`tempfile.gettempdir`.

    Returns
    -------
    Path | str
        The file written, or (nothing written) the reasons each directory refused.
    """
    name = Path(path)
    stamp = time.strftime("%Y%m%d-%H%M%S")
    reasons = []
    try:
        here = [Path.cwd()]
    except OSError as exc:              # the current directory was removed
        here, reasons = [], [f"current directory: {exc.strerror}"]
    for directory in dict.fromkeys([*here, Path(tempfile.gettempdir())]):
        saved = directory / f"{name.stem}-unsaved-{stamp}{name.suffix}"
        if saved.exists() or os.path.realpath(saved) == os.path.realpath(name):
            reasons.append(f"{saved}: exists")
            continue
        try:
            return write_file(saved, data)
        except FileWriteError as exc:
            reasons.append(f"{directory}: {exc.strerror}")
    return "; ".join(reasons)


def _sync_directory(directory: Path) -> None:
    """fsync the directory so the rename survives a power loss; a file system that cannot
    (some network mounts) still has the rename."""
    with contextlib.suppress(OSError):
        fd = os.open(directory, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _error(path: Path, exc: OSError, field: str | None, *, existed: bool) -> FileWriteError:
    reason = exc.strerror or str(exc)
    kept = "the existing file is unchanged" if existed else "nothing was written"
    where = f"{field} {path}" if field else str(path)
    return FileWriteError(f"{where}: cannot write ({reason}); {kept}", path=str(path),
                          strerror=reason, errno=exc.errno, field=field)


__all__ = ["NEW_FILE_MODE", "replace_file", "rescue", "write_file", "write_or_rescue"]
