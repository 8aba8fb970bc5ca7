"""A Gymnasium environment over any scene: :class:`SnakesimEnv`.

::

    env = SnakesimEnv(
        "surface-screw-traverse",
        observation=["tail_pose.pose", "robot.joint_v"],                 # output ports, concatenated
        action={"pid.setpoint": Act(-5.0, 5.0, elements="screw_*", rest="phases.setpoint")},
        reward=progress("tail_pose.pose", 0),                            # m along +x per step
        control_period=0.1, episode_seconds=10.0)
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

The scene is loaded once through the Python API (:func:`snakesim.framework.load`) with the action's
inputs declared open (an input the scene wires is unwired); ``reset`` returns it to its initial state,
``step`` sets the open inputs and advances one control period (a whole number of the scene's base
steps; the inputs hold over it).

Observation
    Output ports (``"comp.port"``), each optionally with bounds and a selection of elements
    (:class:`Obs`), concatenated in the order given into one ``Box`` of ``dtype`` (float32 by
    default). Values are clipped into the declared bounds; a non-finite value (a run that diverged)
    is replaced by the previous observation's, and the episode terminates.
Action
    Open inputs (``"comp.input"``): ``{input: (low, high)}`` or ``{input: Act(low, high, elements=...,
    rest=...)}``. The action space is ``Box(-1, 1)`` (``normalize=True``, the default: what most
    learners expect; element a drives low + (a + 1)/2·(high − low)) or the physical bounds. Actions
    are clipped into the space; a non-finite action is an error. An input's elements the action does
    not drive take ``rest``: a number, an array of the input's shape, or an output port followed each
    step (``"phases.setpoint"``: the scene's own schedule holds the bends while the action drives the
    screws); by default they keep the value the input had at reset.
Reward and termination
    A callable ``f(prev, now, env)``, where ``prev`` and ``now`` are ``{port: value}`` (float64 arrays)
    of the observed ports and the extra ``signals`` at the start and the end of the step, returning a
    float (the reward) or a bool (terminate); or a scene signal ``"comp.port"``: the reward is its
    (scalar) value at the end of the step, the episode terminates when any of its elements is non-zero.
    The episode always terminates when the run ends: a scene's stop rule (a failure: the tail left the
    ground, or a success stop), a component's guard, a blow-up or a non-finite state
    (``info["outcome"]``, ``info["failure_kind"]``, ``info["stop_reason"]`` say which); it is truncated
    after ``episode_seconds``.
Seeded reset
    ``dispersions``: a dispersion file (``snakesim sweep``'s format, docs/campaigns.md), its parsed
    :class:`~snakesim.campaigns.dispersions.DispersionFile`, or a mapping ``{path: {dist: ...}}``.
    After ``reset(seed=s)`` episode k (0, 1, ... until the next seed) runs with the values
    ``snakesim sweep --seed s`` gives run k (a Latin-hypercube entry as a random draw), applied as
    ``--set`` items: a changed value rebuilds the scene (component parameters are frozen at build),
    ~50 ms for the default scene. Without dispersions the scene is deterministic and the seed only
    seeds ``env.np_random`` (for the callables' use). ``info["parameters"]`` gives the episode's values.
"""

from __future__ import annotations

import fnmatch
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import gymnasium
import numpy as np
from gymnasium import spaces

from snakesim.framework import SnakesimError, load
from snakesim.framework.binding import Cell

__all__ = ["SnakesimEnv", "Act", "Obs", "progress"]


@dataclass(frozen=True)
class Obs:
    """An observed output port's bounds (scalars or arrays over the selected elements) and elements
    (names or glob patterns of the port's element names, or indices; None: all)."""

    low: Any = -np.inf
    high: Any = np.inf
    elements: Any = None


@dataclass(frozen=True)
class Act:
    """An action's open input: the bounds of the elements it drives (scalars or arrays), which
    elements (names or glob patterns of the input's element names, or indices; None: all), and what
    the other elements take (``rest``: a number, an array of the input's shape, an output port
    ``"comp.port"`` read every step, or None: the input's value at reset)."""

    low: Any
    high: Any
    elements: Any = None
    rest: Any = None


def progress(port: str, index: int = 0, scale: float = 1.0) -> Callable:
    """A reward: ``scale`` × the change of element ``index`` of ``port`` over the step (the port must be
    observed or listed in ``signals``). ``progress("tail_pose.pose", 0)``: metres the tail moved along
    +x; ``scale=-1``: along −x."""

    def reward(prev: dict, now: dict, env) -> float:
        return scale * float(now[port].reshape(-1)[index] - prev[port].reshape(-1)[index])

    reward.__name__ = reward.__qualname__ = f"progress({port!r}, {index}, scale={scale:g})"
    return reward


def _select(names, size: int, elements, where: str) -> np.ndarray:
    """Indices into a port's flattened elements."""
    if elements is None:
        return np.arange(size)
    items = [elements] if isinstance(elements, (str, int, np.integer)) else list(elements)
    idx: list[int] = []
    for e in items:
        if isinstance(e, (int, np.integer)) and not isinstance(e, bool):
            if not -size <= e < size:
                raise SnakesimError(f"{where}: element {e} is out of range for a port of {size} elements")
            idx.append(int(e) % size)
        elif isinstance(e, str):
            if names is None:
                raise SnakesimError(f"{where}: the port names no elements; select them by index (0 .. {size - 1})")
            hit = [i for i, n in enumerate(names) if n == e or fnmatch.fnmatchcase(n, e)]
            if not hit:
                raise SnakesimError(f"{where}: '{e}' matches no element; elements: {', '.join(names)}")
            idx += hit
        else:
            raise SnakesimError(f"{where}: elements are names, glob patterns or indices, got {e!r}")
    return np.array(sorted(set(idx)), dtype=int)


def _bounds(low, high, n: int, where: str) -> tuple[np.ndarray, np.ndarray]:
    lo = np.broadcast_to(np.asarray(low, dtype=float), (n,)).copy()
    hi = np.broadcast_to(np.asarray(high, dtype=float), (n,)).copy()
    if np.isnan(lo).any() or np.isnan(hi).any() or (lo > hi).any():
        raise SnakesimError(f"{where}: bounds must be numbers with low <= high, got low={low!r}, high={high!r}")
    return lo, hi


def _port_text(port) -> str:
    comp = getattr(port, "component", None)
    return f"{comp.name}.{port.port}" if comp is not None else str(port).strip()


class _Observed:
    __slots__ = ("port", "idx", "low", "high")

    def __init__(self, port, idx, low, high):
        self.port, self.idx, self.low, self.high = port, idx, low, high


class _Driven:
    __slots__ = ("port", "idx", "low", "high", "rest", "shape", "value0")

    def __init__(self, port, idx, low, high, rest, shape, value0):
        self.port, self.idx, self.low, self.high = port, idx, low, high
        self.rest, self.shape, self.value0 = rest, shape, value0


def _load_dispersions(dispersions):
    if dispersions is None:
        return None
    from snakesim.campaigns.dispersions import DispersionFile, load_dispersions, parse_dispersion

    if isinstance(dispersions, DispersionFile):
        return dispersions
    if isinstance(dispersions, (str, Path)):
        return load_dispersions(dispersions)
    if isinstance(dispersions, dict):
        items = tuple(parse_dispersion(str(k), v, "dispersions=") for k, v in dispersions.items())
        if not items:
            return None
        return DispersionFile(path="dispersions=", seed=0, dispersions=items)
    raise SnakesimError(f"dispersions: a dispersion file, a DispersionFile or a mapping {{path: {{dist: ...}}}}, "
                        f"got {type(dispersions).__name__}")


class SnakesimEnv(gymnasium.Env):
    """A scene as a Gymnasium environment (see the module's text)."""

    metadata = {"render_modes": []}

    def __init__(self, scene, *, observation, action, reward=None, terminated=None, signals=(),
                 control_period: float | None = None, episode_seconds: float | None = None, sets=(),
                 config_files=(), dispersions=None, normalize: bool = True, dtype=np.float32,
                 render_mode: str | None = None, registry=None):
        if render_mode is not None:
            raise SnakesimError(f"render_mode={render_mode!r}: this environment does not render "
                                "(record the run, or view it with snakesim replay)")
        self.render_mode = None
        self.scene = scene
        self.sets = tuple(sets)
        self.config_files = tuple(config_files)
        self.registry = registry
        self.normalize = bool(normalize)
        self.dtype = np.dtype(dtype)
        if self.dtype.kind != "f":
            raise SnakesimError(f"dtype: a float type (float32, float64), got {self.dtype}")
        if isinstance(observation, (str, bytes)) or hasattr(observation, "component"):
            observation = [observation]
        self._obs_spec = ({_port_text(k): (v if isinstance(v, Obs) else Obs(*v)) for k, v in observation.items()}
                          if isinstance(observation, dict) else {_port_text(p): Obs() for p in observation})
        if not isinstance(action, dict) or not action:
            raise SnakesimError("action: a mapping {'comp.input': (low, high) or Act(...)}, at least one input")
        self._act_spec = {_port_text(k): (v if isinstance(v, Act) else Act(*v)) for k, v in action.items()}
        if not self._obs_spec:
            raise SnakesimError("observation: at least one output port ('comp.port')")
        as_signal = (lambda f: f if f is None or callable(f) else _port_text(f))    # noqa: E731
        self._reward, self._terminate = as_signal(reward), as_signal(terminated)
        self._signals = tuple(_port_text(s) for s in signals)
        self.dispersions = _load_dispersions(dispersions)
        self._control_period, self._episode_seconds = control_period, episode_seconds

        self.sim = None
        self._sim_sets: tuple | None = None
        self._build(())
        self._disp_seed: int | None = None
        self._episode = -1
        self.parameters: dict = {}
        self.episode_steps = 0
        self._prev: dict | None = None
        self._last_obs: np.ndarray | None = None
        self.last_action: np.ndarray | None = None

    # -- the build ----------------------------------------------------------------------------------
    def _build(self, extra_sets: tuple) -> None:
        sets = self.sets + tuple(extra_sets)
        if self.sim is not None and sets == self._sim_sets:
            self.sim.reset()
            return
        sim = load(self.scene, open=list(self._act_spec), config_files=self.config_files, overrides=list(sets),
                   registry=self.registry)
        first = self.sim is None
        self.sim, self._sim_sets = sim, sets
        self._bind(first)

    def _bind(self, first: bool) -> None:
        """Resolve the ports against the built plan; the spaces on the first build (a rebuild with other
        parameter values must give the same shapes)."""
        sim = self.sim
        plan = sim.plan
        dt = sim.dt
        period = dt if self._control_period is None else float(self._control_period)
        n = int(round(period / dt))
        if n < 1 or abs(n * dt - period) > 1e-9 * max(1.0, period):
            raise SnakesimError(f"control_period = {period:g} s is not a whole number (>= 1) of the scene's base "
                                f"step dt = {dt:g} s")
        seconds = sim.settings.duration if self._episode_seconds is None else float(self._episode_seconds)
        if not seconds > 0:
            raise SnakesimError(f"episode_seconds must be > 0, got {seconds:g}")
        self.steps_per_action, self.control_period = n, n * dt
        self.max_episode_steps = max(1, math.ceil(seconds / self.control_period - 1e-9))
        self.episode_seconds = seconds

        observed, lows, highs = [], [], []
        for port, spec in self._obs_spec.items():
            where = f"observation '{port}'"
            value = sim.value(port)          # an unknown or pruned port says so here
            ref_comp, ref_port = port.rsplit(".", 1)
            comp = plan.components[ref_comp]
            if ref_port not in comp.outputs:
                raise SnakesimError(f"{where}: {ref_comp} has no output '{ref_port}'; outputs: {', '.join(comp.outputs)}")
            if not isinstance(value, np.ndarray) or isinstance(plan.out_buffers.get(_ref(port)), Cell):
                raise SnakesimError(f"{where}: a structured port; observe numeric ports")
            names = comp.outputs[ref_port].signal.element_names(comp)
            idx = _select(names, value.size, spec.elements, where)
            lo, hi = _bounds(spec.low, spec.high, idx.size, where)
            observed.append(_Observed(port, idx, lo, hi))
            lows.append(lo)
            highs.append(hi)
        driven, alow, ahigh = [], [], []
        for port, spec in self._act_spec.items():
            where = f"action '{port}'"
            buf = plan.open_inputs[_ref(port)]
            if isinstance(buf, Cell):
                raise SnakesimError(f"{where}: a structured input; drive numeric inputs")
            ref_comp, ref_port = port.rsplit(".", 1)
            comp = plan.components[ref_comp]
            names = comp.inputs[ref_port].signal.element_names(comp)
            idx = _select(names, buf.size, spec.elements, where)
            lo, hi = _bounds(spec.low, spec.high, idx.size, where)
            if not (np.isfinite(lo).all() and np.isfinite(hi).all()):
                raise SnakesimError(f"{where}: action bounds must be finite")
            rest = spec.rest
            if isinstance(rest, str) or hasattr(rest, "component"):
                rest = _port_text(rest)
                v = np.asarray(sim.value(rest))
                if v.size != buf.size:
                    raise SnakesimError(f"{where}: rest '{rest}' has {v.size} elements, the input {buf.size}")
            elif rest is not None:
                rest = np.broadcast_to(np.asarray(rest, dtype=buf.dtype), buf.shape).copy()
            driven.append(_Driven(port, idx, lo, hi, rest, buf.shape, buf.copy()))
            alow.append(lo)
            ahigh.append(hi)
        for s in (*self._signals, *[f for f in (self._reward, self._terminate) if isinstance(f, str)]):
            sim.value(s)                     # an unknown or pruned port says so at build
        self._observed, self._driven = observed, driven
        obs_low, obs_high = np.concatenate(lows), np.concatenate(highs)
        act_low, act_high = np.concatenate(alow), np.concatenate(ahigh)
        if first:
            info = np.finfo(self.dtype)
            # bounds and values stay representable in dtype (a float64 beyond float32's range is clipped)
            self._clip_low = np.maximum(obs_low, info.min).astype(self.dtype)
            self._clip_high = np.minimum(obs_high, info.max).astype(self.dtype)
            self.observation_space = spaces.Box(obs_low.astype(self.dtype), obs_high.astype(self.dtype),
                                                dtype=self.dtype)
            self._act_low, self._act_high = act_low, act_high
            if self.normalize:
                self.action_space = spaces.Box(-1.0, 1.0, shape=act_low.shape, dtype=self.dtype)
            else:
                self.action_space = spaces.Box(act_low.astype(self.dtype), act_high.astype(self.dtype),
                                               dtype=self.dtype)
        elif obs_low.shape != self.observation_space.shape or act_low.shape != self.action_space.shape:
            raise SnakesimError(f"the scene rebuilt with {self._sim_sets} observes {obs_low.shape} and is driven by "
                                f"{act_low.shape} elements, first built {self.observation_space.shape} and "
                                f"{self.action_space.shape}: a dispersion may not change port shapes")

    # -- reading ------------------------------------------------------------------------------------
    def _snapshot(self) -> dict:
        sim = self.sim
        out = {p: np.asarray(sim.value(p), dtype=float) for p in self._obs_spec}
        for s in self._signals:
            out[s] = np.asarray(sim.value(s), dtype=float)
        return out

    def _observation(self, now: dict) -> tuple[np.ndarray, bool]:
        parts = [now[o.port].reshape(-1)[o.idx] for o in self._observed]
        raw = np.concatenate(parts)
        finite = np.isfinite(raw)
        if not finite.all():
            fill = self._last_obs.astype(float) if self._last_obs is not None else np.zeros_like(raw)
            raw = np.where(finite, raw, fill)
        obs = np.clip(raw, self._clip_low, self._clip_high).astype(self.dtype)
        return obs, bool(finite.all())

    def _info(self) -> dict:
        s = self.sim.summary
        return {"t": self.sim.t, "outcome": s["outcome"], "failure_kind": s["failure_kind"],
                "stop_reason": s["stop_reason"], "parameters": dict(self.parameters)}

    # -- the Gymnasium API --------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Back to the scene's initial state with the next episode's dispersed values (``options``:
        ``{"sets": [...]}``, extra ``--set`` items for this episode only)."""
        super().reset(seed=seed)
        if seed is not None:
            self._disp_seed, self._episode = int(seed), 0
        else:
            if self._disp_seed is None:
                self._disp_seed = int(self.np_random.integers(0, 2 ** 63 - 1))
            self._episode += 1
        extra: list[str] = []
        self.parameters = {}
        if self.dispersions is not None:
            from snakesim.campaigns.dispersions import sample_run, set_item

            self.parameters = sample_run(self.dispersions, self._episode, self._disp_seed)
            extra = [set_item(p, v) for p, v in self.parameters.items()]
        if options:
            bad = set(options) - {"sets"}
            if bad:
                raise SnakesimError(f"reset options: unknown {sorted(bad)}; valid: sets")
            extra += list(options.get("sets", ()))
        self._build(tuple(extra))
        for d in self._driven:                 # the elements no action drives: their value at reset
            if d.rest is None:
                d.value0 = np.asarray(self.sim.value(d.port)).copy()
        self.episode_steps = 0
        self.last_action = None
        self._last_obs = None
        now = self._snapshot()
        obs, _ = self._observation(now)
        self._prev, self._last_obs = now, obs
        return obs, self._info()

    def physical_action(self, action) -> np.ndarray:
        """The action (in the action space) in the inputs' units, elements in the space's order."""
        a = np.asarray(action, dtype=float).reshape(-1)
        if a.shape != self.action_space.shape:
            raise SnakesimError(f"action of shape {a.shape}, the action space is {self.action_space.shape}")
        if not np.isfinite(a).all():
            raise SnakesimError(f"action is not finite: {a}")
        if self.normalize:
            a = np.clip(a, -1.0, 1.0)
            return self._act_low + (a + 1.0) * 0.5 * (self._act_high - self._act_low)
        return np.clip(a, self._act_low, self._act_high)

    def step(self, action):
        if self._prev is None:
            raise SnakesimError("reset() the environment before step()")
        if self.sim.ended:
            raise SnakesimError(f"the episode ended (t = {self.sim.t:g} s, {self.sim.summary['stop_reason']}); "
                                "reset() to start another")
        sim = self.sim
        phys = self.physical_action(action)
        k = 0
        for d in self._driven:
            if isinstance(d.rest, str):
                value = np.asarray(sim.value(d.rest), dtype=float).reshape(-1).copy()
            elif d.rest is not None:
                value = d.rest.reshape(-1).copy()
            else:
                value = d.value0.reshape(-1).copy()
            value[d.idx] = phys[k:k + d.idx.size]
            k += d.idx.size
            sim.set_input(d.port, value.reshape(d.shape))
        self.last_action = phys
        sim.step(self.steps_per_action)
        self.episode_steps += 1
        now = self._snapshot()
        obs, finite = self._observation(now)
        prev = self._prev
        if self._reward is None:
            reward = 0.0
        elif callable(self._reward):
            reward = float(self._reward(prev, now, self))
        else:
            r = np.asarray(sim.value(self._reward), dtype=float).reshape(-1)
            if r.size != 1:
                raise SnakesimError(f"reward '{self._reward}' has {r.size} elements; a reward signal is a scalar")
            reward = float(r[0])
        if not math.isfinite(reward):
            reward, finite = 0.0, False
        terminated = sim.ended or not finite
        if self._terminate is not None and not terminated:
            if callable(self._terminate):
                terminated = bool(self._terminate(prev, now, self))
            else:
                terminated = bool(np.any(np.asarray(sim.value(self._terminate)) != 0))
        truncated = not terminated and self.episode_steps >= self.max_episode_steps
        self._prev, self._last_obs = now, obs
        info = self._info()
        if not finite:
            info["non_finite"] = True
        return obs, reward, terminated, truncated, info

    def close(self):
        self.sim = None
        self._prev = None

    def __repr__(self) -> str:
        return (f"<SnakesimEnv {self.scene}: observation {self.observation_space.shape}, action "
                f"{self.action_space.shape}, {self.control_period:g} s a step, {self.max_episode_steps} steps>")


def _ref(port: str):
    from snakesim.framework.wiring import PortRef

    c, p = port.rsplit(".", 1)
    return PortRef(c, p)
