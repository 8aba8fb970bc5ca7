"""Fingerprints of existing scenes' recorded signals, for the bit-identity check of issue 28 ("with the thermal
components absent, every existing scene's results are bit-identical").

The thermal components (components/thermal/, commit b3a9782) touch no shared file: they wire to the contact
law's ports (screw_mu_scale, screw_ev_scale, screw_sinkage in; screw_slip_power, screw_slip_speed out), which
commit 8635397 (issue 25, "contact-law record") added to every contact back end, its force kernels and their
Jacobians. So the reference is the tree before those ports existed, 8635397's parent 2385d88: no code path a
thermal model uses is in it. This file is written to run unchanged in that tree and in today's:

    git worktree add --detach /tmp/pre_law 2385d88
    mkdir -p /tmp/pp && ln -sfn /tmp/pre_law /tmp/pp/snakesim      # `import snakesim` finds the old tree first
    NUMBA_CACHE_DIR=/tmp/nc_pre PYTHONPATH=/tmp/pp .venv/bin/python tests/thermal/scene_signals.py \
        --write tests/thermal/data/pre_contact_law_signals.json

(the old tree's kernels compile into their own cache; the JSON's `tree` and `commit` say which code ran).
tests/thermal/test_bit_identity.py recomputes the same fingerprints with today's code.

A fingerprint is the sha256 of the recorded rows (float64, C order: every recorded column at every record
tick, `t` first) and of the column names, for each scene run for a short duration with its own defaults.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import subprocess
import sys
from pathlib import Path

# scenes that run the code the contact-law ports went into: the screw SDF contact under the implicit
# integrator (its force kernels and Jacobians: the brace scenes), under the explicit one on a DEM-free
# surface (surface-screw-traverse) and the body contact (walls-body-brace, mini-eels-crawl: body_kernels);
# durations long enough for contact to be made and the brace's loop to act, short enough for a test
SCENES = {"walls-brace-climb": 0.6, "surface-screw-traverse": 0.6, "walls-body-brace": 0.6,
          "mini-eels-crawl": 0.15}


def run(scene: str, duration: float):
    """The scene with its own defaults, for ``duration`` s of simulated time."""
    from snakesim.framework.session import load_session

    return load_session(scene, sim_overrides={"duration": duration}).run()


def fingerprint(result, duration: float) -> dict:
    import numpy as np

    rows = np.ascontiguousarray(result.log.rows, dtype=np.float64)
    return {"duration_s": duration, "rows": int(rows.shape[0]), "columns": len(result.log.columns),
            "columns_sha256": hashlib.sha256("\n".join(result.log.columns).encode()).hexdigest(),
            "signals_sha256": hashlib.sha256(rows.tobytes()).hexdigest()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--write", type=Path, help="write the fingerprints to this JSON file")
    a = ap.parse_args(argv)
    import snakesim.framework     # a namespace package: its framework's folder says which tree runs

    tree = Path(snakesim.framework.__file__).resolve().parents[1]
    commit = subprocess.run(["git", "-C", str(tree), "rev-parse", "HEAD"], capture_output=True, text=True).stdout
    out = {"tree": str(tree), "commit": commit.strip() or None, "scenes": {}}
    for scene, duration in SCENES.items():
        out["scenes"][scene] = fingerprint(run(scene, duration), duration)
        print(scene, out["scenes"][scene], flush=True)
    if a.write:
        a.write.parent.mkdir(parents=True, exist_ok=True)
        a.write.write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
