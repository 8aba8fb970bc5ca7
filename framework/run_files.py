"""Where a run writes, checked before it starts: a long run never ends in a traceback with nothing saved.

``prepare_out_dir`` makes the ``--out`` folder (or refuses it: not a folder, not writable, or holding
files already unless ``overwrite``) and ``check_writable_file`` does the same for one file
(``--save-config``, ``--viz save``). Both write and remove a probe file, so what is checked is what
the run will do, whatever the permission bits say (root, read-only mounts, full disks).

One writer a folder: ``prepare_out_dir`` claims it first, by creating :data:`LOCK_FILE` atomically
(``O_CREAT | O_EXCL``: of two runs started together exactly one succeeds) with the claiming process's
pid, host and start time. A second run refuses the folder naming that process while it lives; a lock
left by a process that is gone (killed) is taken over. The claim is re-entrant within a process and
:func:`release_out_dir` removes it when the run's files are written.

While a run is under way its ``summary.json`` says so (:func:`in_progress_summary`: outcome
``incomplete``, ``completed`` false, who and since when); the finished run replaces it. A folder left by
a killed run therefore reads as incomplete to every reader (``snakesim replay`` says so), never as a
finished run with fewer rows.
"""

from __future__ import annotations

import datetime
import errno
import json
import os
import socket
from pathlib import Path

from .errors import SnakesimError
from .output_files import OutputError, write_file

#: what a run writes into its --out folder (write_run)
RUN_FILES = ("signals.csv", "summary.json", "config.yaml", "last_good_state.npz")
#: the claim of the folder by the run writing it (removed when it ends)
LOCK_FILE = ".snakesim-run.lock"
#: summary.json's outcome while the run is under way, or after it was killed
INCOMPLETE = "incomplete"


def _why(e: OSError) -> str:
    return e.strerror or str(e)


def _probe(folder: Path) -> None:
    probe = folder / f".snakesim-write-test-{os.getpid()}"
    with open(probe, "w") as fh:
        fh.write("x")
    probe.unlink()


def _holder(lock: Path) -> dict:
    try:
        return json.loads(lock.read_text())
    except (OSError, ValueError):
        return {}


def _alive(holder: dict) -> bool:
    """The claiming process still runs (on this host; a claim from another host is taken as alive)."""
    pid = holder.get("pid")
    if not isinstance(pid, int):
        return False
    if holder.get("host") != socket.gethostname():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


#: what os.link raises where the file system has no hard links
NO_HARD_LINKS = (errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.ENOSYS, errno.EMLINK)


def _create_with(lock: Path, text: str) -> None:
    """Create ``lock`` holding ``text`` in one step (FileExistsError if it exists): written to a private file
    first, then hard-linked into place, so no reader ever finds the claim empty and cannot name its holder.
    Where the file system has no hard links, an exclusive create and then the write."""
    private = lock.with_name(f"{lock.name}.{os.getpid()}")
    try:
        private.write_text(text)
        os.link(private, lock)
        return
    except OSError as e:
        if e.errno not in NO_HARD_LINKS:         # FileExistsError (claimed), a full disk: the caller's
            raise
    finally:
        private.unlink(missing_ok=True)
    fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
    with os.fdopen(fd, "w") as fh:
        fh.write(text)


def _claim(path: Path, option: str) -> None:
    """Create the folder's lock atomically for this process (already ours: nothing to do); refuse it while
    another live process holds it; take over a lock whose process is gone."""
    lock = path / LOCK_FILE
    me = {"pid": os.getpid(), "host": socket.gethostname(),
          "started": datetime.datetime.now().astimezone().isoformat(timespec="seconds")}
    for _ in range(2):
        try:
            _create_with(lock, json.dumps(me))
            return
        except FileExistsError:
            holder = _holder(lock)
            if holder.get("pid") == me["pid"] and holder.get("host") == me["host"]:
                return
            if _alive(holder) or not holder:     # unreadable: written this moment where links are missing
                who = (f"pid {holder.get('pid')} on {holder.get('host')}, since {holder.get('started')}"
                       if holder else "a process that is claiming it now")
                raise SnakesimError(f"{option} {path}: another snakesim run is writing there ({who}); wait for "
                                    f"it to end or name another folder (its claim: {lock})")
            lock.unlink(missing_ok=True)         # left by a run that is gone (killed): taken over
    raise SnakesimError(f"{option} {path}: could not claim the folder ({lock} keeps reappearing); "
                        "is another run starting there?")


def release_out_dir(path) -> None:
    """Remove this process's claim of ``path`` (nothing if it holds none)."""
    lock = Path(path) / LOCK_FILE
    holder = _holder(lock)
    if holder.get("pid") == os.getpid() and holder.get("host") == socket.gethostname():
        lock.unlink(missing_ok=True)


def in_progress_summary(source: str) -> dict:
    """summary.json's content while a run is under way (the finished run replaces it)."""
    return {"outcome": INCOMPLETE, "completed": False, "source": source,
            "stop_reason": "the run had not finished when this was written: it is still running, or it was "
                           "killed (signals.csv holds the rows flushed before that)",
            "pid": os.getpid(), "host": socket.gethostname(),
            "started": datetime.datetime.now().astimezone().isoformat(timespec="seconds")}


def error_summary(source: str, error: BaseException) -> dict:
    """summary.json's content for a run that an error ended before it could write its own (a writer on a
    full disk, an exception out of a component): a failure with no kind (``snakesim run`` exits 1), the
    error named, so no reader takes the folder for a run still under way."""
    return {"outcome": "failure", "completed": False, "failure_kind": None, "source": source,
            "stop_reason": f"the run ended with an error: {type(error).__name__}: {error}",
            "error": f"{type(error).__name__}: {error}",
            "ended": datetime.datetime.now().astimezone().isoformat(timespec="seconds")}


def write_error_summary(out_dir, source: str, error: BaseException) -> None:
    """Replace the in-progress summary.json with :func:`error_summary` (best effort: the error may be the
    very disk this cannot write to; the in-progress summary then stands, which still reads as unfinished)."""
    try:
        write_file(Path(out_dir) / "summary.json", json.dumps(error_summary(source, error), indent=2) + "\n")
    except OutputError:
        pass


def prepare_out_dir(path, overwrite: bool = False, option: str = "--out") -> Path:
    """The run folder, made, known writable and claimed by this process (:data:`LOCK_FILE`); a folder that
    already holds files is refused unless ``overwrite`` (then the run's own files are replaced when it
    ends, a stale last_good_state.npz removed), and so is one another live run has claimed."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise SnakesimError(f"{option} {path}: exists and is not a folder; name a new or empty folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
        _claim(path, option)
    except OSError as e:
        raise SnakesimError(f"{option} {path}: cannot write there ({_why(e)}); name a folder you can write to") from None
    if path.is_dir():
        entries = sorted(p.name for p in path.iterdir() if p.name != LOCK_FILE)
        if entries and not overwrite:
            release_out_dir(path)
            shown = ", ".join(entries[:5]) + (f" and {len(entries) - 5} more" if len(entries) > 5 else "")
            raise SnakesimError(f"{option} {path}: the folder is not empty ({shown}); name a new or empty folder, "
                                f"or pass --overwrite to replace the run files in it ({', '.join(RUN_FILES)})")
    try:
        _probe(path)
    except OSError as e:
        release_out_dir(path)
        raise SnakesimError(f"{option} {path}: cannot write there ({_why(e)}); name a folder you can write to") from None
    return path


def check_writable_file(path, option: str) -> Path:
    """``path`` can be written (its folder made if missing); an error naming the option and the reason if not."""
    path = Path(path)
    if path.is_dir():
        raise SnakesimError(f"{option} {path}: is a folder; name a file")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        if path.exists():
            with open(path, "a"):
                pass
        else:
            _probe(path.parent)
    except OSError as e:
        raise SnakesimError(f"{option} {path}: cannot write there ({_why(e)}); name a file in a folder you can "
                            "write to") from None
    return path


def check_writable_dir(path, option: str) -> Path:
    """``path`` is (or is made) a folder this process can write into (a probe file written and removed),
    whatever it holds already (a campaign folder is resumed); an error naming the option, the folder and
    the reason if not. Unlike :func:`prepare_out_dir` it neither claims the folder nor refuses one with
    files in it."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise SnakesimError(f"{option} {path}: exists and is not a folder; name a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
        _probe(path)
    except OSError as e:
        try:
            (path / f".snakesim-write-test-{os.getpid()}").unlink(missing_ok=True)   # a probe a full disk cut
        except OSError:
            pass
        raise SnakesimError(f"{option} {path}: cannot write there ({_why(e)}); name a folder you can "
                            "write to") from None
    return path
