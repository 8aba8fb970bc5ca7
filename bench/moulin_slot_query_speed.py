"""Speed of the slot moulin's compiled query (components/terrain/slot_kernels.py) against the same formulas in
NumPy (tests/terrain/test_moulin_slot.py's reference, the query SlotMoulin had before the kernel), in one process:
a moulin-brace-down scene's real-time factor with each, alternated twice, and the query alone on a step's points.

    .venv/bin/python bench/moulin_slot_query_speed.py [SCENE] [--duration S] [--dt S]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "terrain"))
from test_moulin_slot import _numpy_query  # noqa: E402

from snakesim.components.terrain import load_terrain  # noqa: E402
from snakesim.components.terrain.analytic import SlotMoulin  # noqa: E402
from snakesim.framework.session import load_session  # noqa: E402


def main(argv):
    ap = argparse.ArgumentParser()
    ap.add_argument("scene", nargs="?", default="moulin-brace-down")
    ap.add_argument("--duration", type=float, default=2.0)
    ap.add_argument("--dt", type=float, default=None)
    a = ap.parse_args(argv)
    sim = {"duration": a.duration} | ({"dt": a.dt} if a.dt else {})
    kernel, points = SlotMoulin._query, []

    def numpy_query(self, p):
        return _numpy_query(self, p)

    def recording(self, p):
        points.append(p.copy())
        return kernel(self, p)

    SlotMoulin._query = recording
    load_session(a.scene, sim_overrides={"duration": 0.1}).run()            # JIT warm-up, a step's points
    for name, q in (("numpy", numpy_query), ("kernel", kernel)) * 2:
        SlotMoulin._query = q
        r = load_session(a.scene, sim_overrides=sim).run()
        sm = r.summary
        print(f"{a.scene} dt {sm['dt_s']} s  {name:6s}: sim {sm['sim_time_s']:.2f} s  wall {sm['wall_time_s']:.2f} s  "
              f"real-time factor {sm['real_time_factor']:.3f}", flush=True)
    SlotMoulin._query = kernel
    t = load_terrain(load_session(a.scene).plan.components["terrain"].p.name)     # the scene's terrain
    p = max(points, key=len)
    for name, f in (("numpy", lambda: _numpy_query(t, p)), ("kernel", lambda: t._query(p))):
        n = 200
        t0 = time.perf_counter()
        for _ in range(n):
            f()
        print(f"query of {len(p)} points, {name:6s}: {1e3 * (time.perf_counter() - t0) / n:.3f} ms")


if __name__ == "__main__":
    main(sys.argv[1:])
