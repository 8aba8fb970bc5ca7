"""Every file a command writes, one rule: whole or not at all, and a clear error when the disk says no.

``write_file(path, data)`` writes the bytes to a temporary name in the same folder
(``.NAME.PID.tmp``), fsyncs it and moves it into place with ``os.replace``: a reader never sees a
half-written file, and a failure (a full disk, a read-only or missing folder, a path through a regular
file) removes the temporary file and leaves what was there before. An ``OSError`` becomes a
:class:`OutputError` (a :class:`SnakesimError`: the CLI prints it and exits non-zero) naming the
file and the cause. ``make_dir`` does the same for a folder, ``append_line`` for an append-only log
(a failed append is cut back to the previous end: no torn line), and :class:`OutputSet` removes what one
command wrote when a later file of the same command fails (``snakesim robot urdf``: meshes and
sidecar first, the URDF last).

Every write goes through :func:`_write_all`, so a test can make the Nth write fail (ENOSPC) on any
file system.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path

from .errors import SnakesimError


class OutputError(SnakesimError):
    """A file could not be written (its name and the operating system's reason)."""


_HINTS = {errno.ENOSPC: "the disk is full", errno.EDQUOT: "the disk quota is exceeded",
          errno.EROFS: "the file system is read-only"}


def output_error(path, e: OSError, what: str = "cannot write") -> OutputError:
    """The error for ``e`` while writing ``path``: the file, the cause, what to do."""
    why = e.strerror or str(e)
    hint = _HINTS.get(e.errno)
    if isinstance(e, NotADirectoryError):
        hint = "a folder on the path is a regular file"
    elif isinstance(e, FileExistsError):
        hint = "a file of that name is in the way"
    todo = "free some space or write elsewhere" if e.errno in (errno.ENOSPC, errno.EDQUOT) else \
        "name a place you can write to"
    return OutputError(f"{what} {path}: {why}" + (f" ({hint})" if hint and hint not in why.lower() else "")
                       + f"; nothing partial was left: {todo}")


def _write_all(fh, data: bytes) -> None:
    """The one write of every output file (tests replace it to simulate a full disk)."""
    fh.write(data)


def _tmp_name(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def make_dir(path) -> Path:
    """``path`` and its parents, made; an :class:`OutputError` naming it if that is not possible."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise OutputError(f"cannot make the folder {path}: a file of that name is in the way; name another place")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise output_error(path, e, "cannot make the folder") from None
    if not path.is_dir():
        raise OutputError(f"cannot make the folder {path}: a file of that name is in the way")
    return path


def write_file(path, data: bytes | str, *, fsync: bool = True) -> Path:
    """Write ``data`` (str: UTF-8) to ``path`` whole or not at all (temporary file, fsync, ``os.replace``);
    an :class:`OutputError` naming ``path`` and the cause on failure, the temporary file removed."""
    path = Path(path)
    tmp = _tmp_name(path)
    raw = data.encode("utf-8") if isinstance(data, str) else bytes(data)
    try:
        with open(tmp, "wb") as fh:
            _write_all(fh, raw)
            fh.flush()
            if fsync:
                os.fsync(fh.fileno())
        os.replace(tmp, path)
    except OSError as e:
        try:
            tmp.unlink(missing_ok=True)
        except OSError:
            pass
        raise output_error(path, e) from None
    return path


def append_line(path, line: bytes | str) -> None:
    """Append one line (one write, then fsync); on failure the file is cut back to its previous end, so
    it holds no torn line, and an :class:`OutputError` names it."""
    path = Path(path)
    raw = line.encode("utf-8") if isinstance(line, str) else bytes(line)
    try:
        size = path.stat().st_size
    except FileNotFoundError:
        size = 0
    except OSError as e:
        raise output_error(path, e) from None
    try:
        with open(path, "ab") as fh:
            _write_all(fh, raw)
            fh.flush()
            os.fsync(fh.fileno())
    except OSError as e:
        try:
            with open(path, "r+b") as fh:
                fh.truncate(size)
        except OSError:
            pass
        raise output_error(path, e) from None


class OutputSet:
    """The files (and folders) one command creates, removed again if a later one fails::

        with OutputSet() as out:
            out.make_dir(mesh_dir)
            out.write(mesh, data)      # ...
            out.write(urdf, text)      # last: what the others serve

    A file that existed before is replaced (atomically) and not removed; only what this command
    created is."""

    def __init__(self):
        self.created: list[Path] = []

    def make_dir(self, path) -> Path:
        path = Path(path)
        missing = []
        p = path
        while not p.exists() and p != p.parent:
            missing.append(p)
            p = p.parent
        make_dir(path)
        self.created += reversed(missing)
        return path

    def write(self, path, data: bytes | str) -> Path:
        path = Path(path)
        existed = path.exists()
        write_file(path, data)
        if not existed:
            self.created.append(path)
        return path

    def remove_all(self) -> None:
        for p in reversed(self.created):
            try:
                p.rmdir() if p.is_dir() else p.unlink(missing_ok=True)
            except OSError:
                pass        # a folder that holds other files stays
        self.created.clear()

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is not None:
            self.remove_all()
        return False
