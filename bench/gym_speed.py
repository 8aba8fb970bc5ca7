"""snakesim.gym throughput: environment steps per second of one environment and of Gymnasium's vector
environments over the local process pool.

One registered environment (default ``snakesim/ScrewTraverse-v0``: 0.1 s of the default scene per step,
its dispersions on, so every reset rebuilds the scene with new values), episodes of ``--episode-seconds``
(reset when one ends), driven by two policies:

    uniform        a new uniform random action every step (early exploration: the screws' set-points
                   jump by up to 10 rad/s every 0.1 s, and the error-controlled integrator takes many
                   small steps after each jump)
    random walk    the action moves by N(0, 0.1) a step, clipped to [-1, 1] (a smooth policy)

each measured three ways, interleaved ``--repeats`` times, the best of each counting (the machine is
shared and its speed drifts):

    one env        env.step (and env.reset when an episode ends) in this process
    sync vector    gymnasium.vector.SyncVectorEnv of --workers envs in this process (the same work, in turn)
    async vector   gymnasium.vector.AsyncVectorEnv of --workers envs, one worker process each; the pool is
                   started and warmed (imports, numba caches, the first build) once, outside the timing

    env steps/s    environment steps (one per env per vector step) / wall time; ``× sim`` is the simulated
                   time per wall second (steps/s × control period)
    ratio          async / one env (goal >= 1.8 with 2 workers on 2 free cores)
    cores got      CPU seconds of the process(es) that step the envs / wall time

    python bench/gym_speed.py [--env snakesim/ScrewTraverse-v0] [--steps 300] [--workers 2] [--repeats 2]
                              [--episode-seconds 5] [--json bench/results/gym_speed.json]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np

GOAL_RATIO = 1.8


def _make(env_id: str, episode_seconds: float):
    import gymnasium

    import snakesim.gym  # noqa: F401  (registers the ids)

    return gymnasium.make(env_id, episode_seconds=episode_seconds)


def _maker(env_id: str, episode_seconds: float):
    def make():
        return _make(env_id, episode_seconds)
    return make


class Policy:
    """Actions of shape ``shape``: ``uniform`` or ``random walk`` (see the module's text)."""

    def __init__(self, kind: str, shape, seed: int):
        self.kind, self.rng = kind, np.random.default_rng(seed)
        self.a = np.zeros(shape)

    def __call__(self) -> np.ndarray:
        if self.kind == "uniform":
            self.a = self.rng.uniform(-1, 1, self.a.shape)
        else:
            self.a = np.clip(self.a + self.rng.normal(0, 0.1, self.a.shape), -1, 1)
        return self.a.astype(np.float32)


POLICIES = ("uniform", "random walk")


def one_env(env, steps: int, seed: int, policy: str = "uniform") -> dict:
    act = Policy(policy, env.action_space.shape, seed)
    env.reset(seed=seed)
    resets, reset_s = 0, 0.0
    cpu0, t0 = time.process_time(), time.perf_counter()
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(act())
        if terminated or truncated:
            r0 = time.perf_counter()
            env.reset()
            reset_s += time.perf_counter() - r0
            resets += 1
    wall = time.perf_counter() - t0
    return {"env_steps_per_s": steps / wall, "wall_s": wall, "cores_got": (time.process_time() - cpu0) / wall,
            "resets": resets, "ms_per_reset": 1e3 * reset_s / resets if resets else None}


def vector(venv, steps: int, seed: int, policy: str = "uniform", pids=()) -> dict:
    """``steps`` vector steps (num_envs env steps each); CPU time of this process and the worker pids."""
    act = Policy(policy, venv.action_space.shape, seed)
    venv.reset(seed=seed)
    cpu0, wcpu0, t0 = time.process_time(), _cpu(pids), time.perf_counter()
    for _ in range(steps):
        venv.step(act())
    wall = time.perf_counter() - t0
    cpu = time.process_time() - cpu0 + _cpu(pids) - wcpu0
    return {"env_steps_per_s": steps * venv.num_envs / wall, "wall_s": wall, "cores_got": cpu / wall}


def _cpu(pids) -> float:
    """CPU seconds (user + system) of processes, from /proc (Linux; 0 elsewhere)."""
    total = 0.0
    for pid in pids:
        try:
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
            total += (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
        except (OSError, IndexError, ValueError):
            pass
    return total


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--env", default="snakesim/ScrewTraverse-v0")
    ap.add_argument("--steps", type=int, default=300, help="env steps per measurement (vector: steps x envs)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--episode-seconds", type=float, default=5.0)
    ap.add_argument("--json", type=Path, default=Path(__file__).parent / "results" / "gym_speed.json")
    a = ap.parse_args(argv)

    from gymnasium.vector import AsyncVectorEnv, SyncVectorEnv

    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    t0 = time.perf_counter()
    env = _make(a.env, a.episode_seconds)
    first_make_s = time.perf_counter() - t0
    u = env.unwrapped
    period = u.control_period
    one_env(env, 10, 0)                                          # warm: compiled code, the first rebuilds
    sync = SyncVectorEnv([_maker(a.env, a.episode_seconds) for _ in range(a.workers)])
    vector(sync, 5, 0)
    t0 = time.perf_counter()
    pool = AsyncVectorEnv([_maker(a.env, a.episode_seconds) for _ in range(a.workers)])
    vector(pool, 5, 0)
    pool_start_s = time.perf_counter() - t0
    pids = [p.pid for p in pool.processes]

    runs = {p: {"one env": [], "sync vector": [], "async vector": []} for p in POLICIES}
    for rep in range(a.repeats):
        for p in POLICIES:
            runs[p]["one env"].append(one_env(env, a.steps, 100 + rep, p))
            runs[p]["sync vector"].append(vector(sync, a.steps // a.workers, 200 + rep, p))
            runs[p]["async vector"].append(vector(pool, a.steps // a.workers, 300 + rep, p, pids))
    pool.close()
    sync.close()
    best = {p: {k: max(v, key=lambda r: r["env_steps_per_s"]) for k, v in runs[p].items()} for p in POLICIES}
    ratio = {p: best[p]["async vector"]["env_steps_per_s"] / best[p]["one env"]["env_steps_per_s"] for p in POLICIES}

    print(f"{a.env}: {period:g} s a step ({u.steps_per_action} base steps of {u.sim.dt:g} s), episodes of "
          f"{a.episode_seconds:g} s ({u.max_episode_steps} steps), dispersions "
          f"{'on: a rebuild every reset' if u.dispersions is not None else 'off'}; observation "
          f"{u.observation_space.shape}, action {u.action_space.shape}")
    print(f"{os.cpu_count()} cores, load average {load:.2f} before; {a.workers} workers; best of {a.repeats}, "
          f"interleaved; first make {first_make_s:.2f} s, async pool start-up + warm-up {pool_start_s:.2f} s\n")
    print("| policy | how | env steps/s | × sim | ms per env step | cores got |")
    print("|---|---|---:|---:|---:|---:|")
    for p in POLICIES:
        for k, r in best[p].items():
            name = k if k == "one env" else f"{k}, {a.workers} envs"
            print(f"| {p} | {name} | {r['env_steps_per_s']:.0f} | {r['env_steps_per_s'] * period:.1f} | "
                  f"{1e3 / r['env_steps_per_s']:.2f} | {r['cores_got']:.2f} |")
    print()
    for p in POLICIES:
        reset_ms = best[p]["one env"]["ms_per_reset"]
        print(f"{p}: ratio async / one env {ratio[p]:.2f} (goal >= {GOAL_RATIO} with 2 workers on 2 free cores)"
              + (f"; a reset (a rebuild with the episode's dispersed values) {reset_ms:.0f} ms" if reset_ms else ""))

    result = {"env": a.env, "control_period_s": period, "episode_seconds": a.episode_seconds,
              "max_episode_steps": u.max_episode_steps, "dispersions": u.dispersions is not None,
              "workers": a.workers, "steps": a.steps, "repeats": a.repeats, "cores": os.cpu_count(),
              "load_average_before": load, "machine": platform.platform(), "processor": platform.processor(),
              "first_make_s": first_make_s, "async_pool_start_s": pool_start_s, "best": best, "runs": runs,
              "ratio_async_to_one": ratio}
    env.close()
    if a.json:
        a.json.parent.mkdir(parents=True, exist_ok=True)
        a.json.write_text(json.dumps(result, indent=2))
        print(f"wrote {a.json}")
    return result


if __name__ == "__main__":
    main()
