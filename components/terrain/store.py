"""Terrain store: derived grids (mesh SDFs) cached on disk, keyed by content hash.

Like SimScape's store in the paper: a conversion is paid once, then any run
or project loading the same mesh with the same grid parameters reads the
.npz. Folder: the ``store`` argument, else $SNAKESIM_TERRAIN_STORE, else
~/.cache/snakesim/terrain-store.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import numpy as np

ENV_VAR = "SNAKESIM_TERRAIN_STORE"


def store_dir(store: str | Path | None = None) -> Path:
    if store is None:
        store = os.environ.get(ENV_VAR) or Path.home() / ".cache" / "snakesim" / "terrain-store"
    return Path(store).expanduser()


def content_key(data: bytes, params: dict) -> str:
    """sha256 of the source bytes and the (JSON-sorted) conversion parameters."""
    h = hashlib.sha256(data)
    h.update(json.dumps(params, sort_keys=True).encode())
    return h.hexdigest()


def load_entry(key: str, store=None) -> dict | None:
    path = store_dir(store) / f"{key}.npz"
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as f:
            return {k: f[k] for k in f.files}
    except Exception:  # a truncated or foreign file: recompute rather than fail
        return None


def save_entry(key: str, arrays: dict, store=None) -> Path:
    folder = store_dir(store)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{key}.npz"
    tmp = folder / f".{key}.{os.getpid()}.tmp.npz"
    np.savez_compressed(tmp, **arrays)
    os.replace(tmp, path)          # atomic: concurrent runs never read a half-written entry
    return path
