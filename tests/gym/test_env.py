"""snakesim.gym: any scene as a Gymnasium environment, and the registered ids (docs/python.md)."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import warnings

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

import snakesim.gym as sgym  # noqa: E402
from snakesim.framework import SnakesimError  # noqa: E402

SCREW = "snakesim/ScrewTraverse-v0"


@pytest.fixture(scope="module")
def screw_env():
    env = gymnasium.make(SCREW)
    yield env
    env.close()


def rollout(env, seed, actions):
    """(observations, rewards, terminated flags, the state at the end) of one episode from reset(seed)."""
    obs, info = env.reset(seed=seed)
    out, rewards, ends = [obs], [], []
    for a in actions:
        obs, r, terminated, truncated, info = env.step(a)
        out.append(obs)
        rewards.append(r)
        ends.append(terminated or truncated)
    return np.array(out), np.array(rewards), ends, env.unwrapped.sim.state(), info


def test_the_registered_env_passes_gymnasiums_checker(screw_env):
    from gymnasium.utils.env_checker import check_env

    env = screw_env.unwrapped
    assert isinstance(env, sgym.ScrewTraverseEnv) and env.spec.id == SCREW
    assert env.observation_space.shape == (33,) and env.action_space.shape == (10,)
    assert env.observation_space.dtype == np.float32 and env.max_episode_steps == 100
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env)
    gym_warnings = [str(w.message) for w in caught if "gymnasium" in w.filename]
    assert not gym_warnings, gym_warnings


def test_make_works_from_the_installed_metadata_in_a_fresh_process(tmp_path):
    """No snakesim import first: the 'module:id' form imports snakesim.gym, and the gymnasium.envs entry
    point (what Gymnasium 0.26-0.29 loads at import) names the function that registers the ids. Run away
    from the sources, so the installed metadata is read (not a snakesim.egg-info in the working tree)."""
    code = textwrap.dedent("""
        from importlib.metadata import entry_points
        import gymnasium
        assert "snakesim/ScrewTraverse-v0" not in gymnasium.registry
        (ep,) = [e for e in entry_points(group="gymnasium.envs") if e.name == "snakesim"]
        ep.load()()
        assert {"snakesim/ScrewTraverse-v0", "snakesim/MiniEelsCrawl-v0"} <= set(gymnasium.registry)
        env = gymnasium.make("snakesim.gym:snakesim/ScrewTraverse-v0")
        obs, info = env.reset(seed=0)
        print(env.unwrapped.spec.id, obs.shape, env.step(env.action_space.sample())[0].dtype)
    """)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split("\n")[0] == "snakesim/ScrewTraverse-v0 (33,) float32"


def test_forward_screws_move_the_tail_forward_and_reverse_back(screw_env):
    """The crescent's chord lies along +x: all screws forward drive the tail along +x (paper 4.2's first
    phase), all reversed back along −x; the reward is the tail's progress along +x."""
    forward = rollout(screw_env, 0, [np.ones(10)] * 10)
    backward = rollout(screw_env, 0, [-np.ones(10)] * 10)
    idle = rollout(screw_env, 0, [np.zeros(10)] * 10)
    assert forward[1].sum() > 0.1 and (forward[1][3:] > 0).all()          # m in 1 s at 5 rad/s
    assert backward[1].sum() < -0.1 and (backward[1][3:] < 0).all()
    assert abs(idle[1].sum()) < 2e-3                                       # screws held: it stays
    x0 = forward[0][0][0]
    assert forward[1].sum() == pytest.approx(forward[0][-1][0] - x0, abs=1e-6)    # the rewards add up to x


def test_the_same_seed_gives_the_same_trajectory_bit_for_bit(screw_env):
    rng = np.random.default_rng(5)
    actions = list(rng.uniform(-1, 1, size=(8, 10)))
    a = rollout(screw_env, 3, actions)
    b = rollout(screw_env, 3, actions)                 # the same env, again
    other = gymnasium.make(SCREW)                       # and a second env
    c = rollout(other, 3, actions)
    for r in (b, c):
        assert np.array_equal(a[0], r[0]) and np.array_equal(a[1], r[1])
        assert all(np.array_equal(a[3][k], r[3][k]) for k in a[3])
        assert a[4]["parameters"] == r[4]["parameters"]
    d = rollout(screw_env, 4, actions)                 # another seed: other dispersed values, another run
    assert d[4]["parameters"] != a[4]["parameters"]
    assert not np.array_equal(a[0], d[0]) and not np.array_equal(a[1], d[1])
    other.close()


def test_episode_k_after_a_seed_is_the_sweeps_run_k(screw_env):
    from snakesim.campaigns.dispersions import sample

    env = screw_env.unwrapped
    runs = sample(env.dispersions, 3, seed=11)
    got = [env.reset(seed=11)[1]["parameters"], env.reset()[1]["parameters"], env.reset()[1]["parameters"]]
    assert got == runs
    crescent = env.sim.components["robot"].p.q0
    assert crescent == {"bend_*": runs[2]["crescent_bend"]}          # the scene was rebuilt with them


def test_a_blow_up_terminates_the_episode():
    """RK4 at the scene's 20 ms step is far past the contact's stability bound: the multibody's blow-up
    guard ends the run at t = 0.14 s (README), and the episode with it."""
    env = sgym.ScrewTraverseEnv(sets=["sim.integrator=rk4"], dispersions=None)
    env.reset(seed=0)
    for _ in range(10):
        obs, reward, terminated, truncated, info = env.step(np.zeros(10))
        assert np.isfinite(obs).all() and env.observation_space.contains(obs) and np.isfinite(reward)
        if terminated:
            break
    assert terminated and not truncated
    assert info["outcome"] == "failure" and info["failure_kind"] == "blow_up" and info["t"] == pytest.approx(0.14)
    with pytest.raises(SnakesimError, match="episode ended"):
        env.step(np.zeros(10))
    env.reset(seed=0)                                   # and it starts again
    assert env.step(np.zeros(10))[2] is False


def test_a_scene_stop_and_a_termination_callable_end_the_episode():
    stop = "stop=[{signal: tail_pose.pose, index: 0, above: 0.05, reason: past 5 cm}]"
    env = sgym.ScrewTraverseEnv(sets=[stop], dispersions=None)
    env.reset(seed=0)
    steps = 0
    while True:
        obs, reward, terminated, truncated, info = env.step(np.ones(10))
        steps += 1
        if terminated or truncated:
            break
    assert terminated and info["failure_kind"] == "stop_rule" and "past 5 cm" in info["stop_reason"]
    assert obs[0] > 0.05 and steps < 10

    env = sgym.ScrewTraverseEnv(dispersions=None, episode_seconds=0.5,
                                terminated=lambda prev, now, env: now["tail_pose.pose"][0] < -0.02)
    env.reset(seed=0)
    for k in range(5):
        obs, reward, terminated, truncated, info = env.step(-np.ones(10))
        if terminated or truncated:
            break
    assert terminated and not truncated and info["outcome"] is None      # the callable's: the run goes on
    assert obs[0] < -0.02 and k < 4
    env.reset(seed=0)
    ends = [env.step(np.zeros(10))[2:4] for _ in range(5)]
    assert ends == [(False, False)] * 4 + [(False, True)]          # truncated at episode_seconds


def test_any_scene_with_signals_for_reward_and_termination():
    """The pendulum, driven by its pivot torque (the damper unwired): a reward signal, a seed without
    dispersions (np_random), physical action bounds, element selection by index."""
    env = sgym.SnakesimEnv("pendulum", observation={"pend.theta": (-4, 4), "pend.omega": (-20, 20)},
                           action={"pend.tau": (-2.0, 2.0)}, reward="pend.theta", terminated="pend.omega",
                           control_period=0.01, episode_seconds=1.0, normalize=False, dtype=np.float64)
    assert env.action_space.low[0] == -2.0 and env.max_episode_steps == 100 and env.steps_per_action == 10
    obs, info = env.reset(seed=1)
    assert obs.dtype == np.float64 and obs[0] == 0.2 and info["parameters"] == {}
    n1 = env.np_random.random()
    obs, reward, terminated, truncated, info = env.step([3.0])         # clipped to 2 N·m
    assert reward == obs[0] and terminated                             # omega != 0: the signal ends it
    assert env.last_action[0] == 2.0 and env.sim.value("pend.tau") == 2.0
    env.reset(seed=1)
    assert env.np_random.random() == n1
    with pytest.raises(SnakesimError, match="whole number"):
        sgym.SnakesimEnv("pendulum", observation=["pend.theta"], action={"pend.tau": (-1, 1)}, control_period=0.0015)
    with pytest.raises(SnakesimError, match="matches no element"):
        sgym.SnakesimEnv("surface-screw-traverse", observation=["tail_pose.pose"],
                         action={"pid.setpoint": sgym.Act(-1, 1, elements="propeller_*")})


def test_mini_eels_crawls_tail_first_with_its_gait():
    from gymnasium.utils.env_checker import check_env

    env = gymnasium.make("snakesim/MiniEelsCrawl-v0", episode_seconds=0.5)
    check_env(env.unwrapped, skip_close_check=True)
    env.unwrapped.dispersions = None                    # the scene's own skin from here
    obs, info = env.reset(seed=0)
    assert obs.shape == env.observation_space.shape == (23,) and env.action_space.shape == (2,)
    total = sum(env.step(np.array([0.4, 0.0]))[1] for _ in range(5))    # the scene's 0.7 rad, 0.5 Hz
    assert total > 0.0
    env.close()


def test_without_gymnasium_the_import_names_the_extra():
    code = ("import sys; sys.modules['gymnasium'] = None\n"
            "try:\n    import snakesim.gym\nexcept ImportError as e:\n    print(e)\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert "pip install 'snakesim[gym]'" in proc.stdout, proc.stdout + proc.stderr
