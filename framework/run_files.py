"""Where a run writes, checked before it starts: a long run never ends in a traceback with nothing saved.

``prepare_out_dir`` makes the ``--out`` folder (or refuses it: not a folder, not writable, or holding
files already unless ``overwrite``) and ``check_writable_file`` does the same for one file
(``--save-config``, ``--viz save``). Both write and remove a probe file, so what is checked is what
the run will do, whatever the permission bits say (root, read-only mounts, full disks).
"""

from __future__ import annotations

import os
from pathlib import Path

from .errors import SnakesimError

#: what a run writes into its --out folder (write_run)
RUN_FILES = ("signals.csv", "summary.json", "config.yaml", "last_good_state.npz")


def _why(e: OSError) -> str:
    return e.strerror or str(e)


def _probe(folder: Path) -> None:
    probe = folder / f".snakesim-write-test-{os.getpid()}"
    with open(probe, "w") as fh:
        fh.write("x")
    probe.unlink()


def prepare_out_dir(path, overwrite: bool = False, option: str = "--out") -> Path:
    """The run folder, made and known writable; a folder that already holds files is refused unless
    ``overwrite`` (then the run's own files are replaced when it ends, a stale last_good_state.npz
    removed)."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise SnakesimError(f"{option} {path}: exists and is not a folder; name a new or empty folder")
    if path.is_dir():
        entries = sorted(p.name for p in path.iterdir())
        if entries and not overwrite:
            shown = ", ".join(entries[:5]) + (f" and {len(entries) - 5} more" if len(entries) > 5 else "")
            raise SnakesimError(f"{option} {path}: the folder is not empty ({shown}); name a new or empty folder, "
                                f"or pass --overwrite to replace the run files in it ({', '.join(RUN_FILES)})")
    try:
        path.mkdir(parents=True, exist_ok=True)
        _probe(path)
    except OSError as e:
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
