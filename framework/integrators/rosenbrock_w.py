"""Linearly implicit Rosenbrock W-methods on the components' own Jacobian (stiff contact, PIDs).

A W-method keeps its order for *any* matrix in place of the Jacobian; only its stability depends
on it. So J need only carry the stiff terms, and here it is what the components declare
(:mod:`snakesim.framework.linearization`: the contact's spring-damper and regularised-friction
slopes through the contact points' Jacobians, the PID gains, the mass matrix), assembled
analytically in one pass, never by finite differences; what no component declares is integrated
explicitly, at the explicit method's stability limit. A robot at rest is a fixed point of every
method here at any step: f(x*) = 0 gives zero stage slopes.

``method``:

``ros2`` (default) Verwer, Spee, Blom & Hundsdorfer, SIAM J. Sci. Comput. 20 (1999): 2 stages,
    order 2 for any W, L-stable, not stiffly accurate::

        W k1 = f(x),  W k2 = f(x ⊕ h k1) − 2 k1,  x₊ = x ⊕ h (3/2 k1 + 1/2 k2),  W = I − γhJ, γ = 1 + 1/√2

    Robust where the friction regularisation makes the problem both very stiff and strongly
    nonlinear (held robots: the walls hold, the default scene's stop phase creep at the
    converged rate at 10 ms; bench/held_cases.py). While driving its tail error grows ∝ h
    (the contact's onset is not smooth): 5.3 mm over the 45 s traverse at 5 ms, 20 mm at 10 ms.
    ``jacobian_every: 3`` at 5 ms keeps 6.6 mm / 0.003 rad there (11 mm at 5) and the held cases
    within 0.2 % of their converged creep, for ~25 % less time per step (bench/tradeoff.py).
``ros34pw2`` Rang & Angermann, BIT 45 (2005): 4 stages, order 3 for any W, L-stable and stiffly
    accurate (the last stage is the solution), built so that index-1 DAEs keep order 3. More
    accurate while driving (7.1 mm over the 45 s traverse at 10 ms), but its internal stages
    overshoot the friction's narrow linear range on held robots: the stop phase creeps 2.5x
    too fast at 10 ms and the walls hold slides even at 2 ms.
    Transformed (U) form, Hairer & Wanner II, sec. IV.7::

        (1/(γh) I − J) U_i = f(x ⊕ Σ_j a_ij U_j) + Σ_j (c_ij / h) U_j,     x₊ = x ⊕ Σ m_i U_i

    with a = AΓ⁻¹, c = diag(1/γ) − Γ⁻¹, m = bᵀΓ⁻¹ from the method's (α, γ, b).

``jacobian_refresh``: when J is assembled. ``steps`` (default): every ``jacobian_every`` steps.
``on_sources``: also at a step where a time-driven source (a component with no inputs and no
continuous state: a schedule, a sampled source) shows a value other than at the step
before, and at every step for ``refresh_window`` s after; ``refresh_substeps`` splits the steps of
that window into as many equal steps. Where the stiff terms' slopes move fast in a driven scene is
the transient after a set-point jump (the screws spin up, the friction's slip regime changes): a
stale J, or a large step, costs accuracy there and hardly anywhere else, so between jumps J can be
kept for many steps and the step made large. On the 45 s default traverse (bench/tradeoff.py, one
run, against RK4 at 0.25 ms): 5 ms, ``jacobian_every: 8``, window 50 ms: 5.3 mm / 0.0028 rad (as
with J at every step; ``jacobian_every: 3`` without the rule: 6.6 mm, 4: 10.4 mm); 10 ms,
``jacobian_every: 8``, window 100 ms at 4 substeps: 4.3 mm / 0.0020 rad (J at every step, no
substeps: 19.5 mm), ~2.8x MuJoCo's speed; the held cases (bench/held_cases.py) within 0.2 %. A
window under ~3 steps loses it (window 0 at 1/150 s: 14 mm on the compressed schedule). The watch
is a compare of the sources' outputs with a copy at each step (a few hundred ns).

``step_control``: how a base step is split. ``error`` (default): into 2^level equal steps, the level set by
the method's embedded estimate (ros2: x₊ − (x0 ⊕ h ka) = h/2 (ka + kb), the linearly implicit Euler
solution inside it, Verwer et al. 1999; ros34pw2: its order-2 weights b̂), filtered through W⁻¹
(Shampine; ``error_filter``) and measured against ``atol_q`` (each position coordinate's change), ``atol_v``
(each velocity) and ``rtol`` (of |v|, or of the change) in the max norm: a step over 1 is taken again at
the level 0.9 e^−½ asks for, J assembled afresh at the step's start if it was older; accepted steps let the
level fall where the estimate allows and the step's end lies on the coarser grid. The base step stays the
control period (records, stops, discrete updates, ROS 2 lockstep see the same instants) and steps land on it
exactly; their few sizes keep their factorisations' bound solves (Linearization.bind_solve). Contact onset,
lift-off and impacts (a stage that meets the ice with no contact stiffness in J integrates k and c
explicitly) are found by the estimate and taken in short steps; persistent contact at the base step. A step
that would have to be shorter than ``h_min`` fails the run, naming the time and the tolerances. Defaults
(3e-4 m, 3e-3 m/s, 3e-3) keep a tumbling free robot's energy and momenta within 0.1 %/s at a 10 ms base
step; the default scene, on the ground, runs 3e-3 / 3e-2 / 3e-2 at 20 ms. ``fixed``: ``substeps`` equal
steps per base step (``refresh_substeps`` in a source's refresh window), the former behaviour (to round-off:
W is no longer refactorised when h changes only in its last bits, as t1 − t0 does); only the contacts' look-ahead (screw_sdf's ``lookahead_time``) then meets the ice implicitly, at a
Jacobian assembly.

Stage slopes evaluated at x ⊕ u are mapped back to the chart at x (``dexp_inv``, Munthe-Kaas)
as in the explicit methods. Cost per step: ``stages`` evaluations of f (the first is the
simulator's) and as many structured solves; per Jacobian refresh (``jacobian_every`` steps) one
assembly and one factorisation per multibody: O(links) on its link tree (the articulated-body
elimination of components/multibody/articulated_solve_kernels.py; 100 EELS 1.0 modules, nv = 306:
~0.06 ms against 4.7 ms for the dense LU it replaced), a dense (nv × nv) LU where the tree
elimination does not apply (framework/linearization.py).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numba import njit
from pydantic import Field, model_validator

from ..linear_solve_kernels import bind
from ..linearization import Linearization
from ..errors import SnakesimError
from .base import FixedStep, FixedStepParams


# ROS2's vector updates, bound to the work arrays (h in a one-element array): the same operations as
# NumPy's ``dx = h ka``, ``f -= 2 ka``, ``dx = 1.5h ka; dx += 0.5h kb``, without a ufunc call each
@njit(cache=True)
def _ros2_offset(ka, h, dx):
    for i in range(dx.size):
        dx[i] = ka[i] * h[0]


@njit(cache=True)
def _changed(live, seen):
    """True if ``live`` differs from ``seen`` (then copied into it)."""
    for i in range(live.size):
        if live[i] != seen[i]:
            seen[:] = live
            return True
    return False


@njit(cache=True)
def _ros2_rhs(f, ka):
    for i in range(f.size):
        f[i] -= 2.0 * ka[i]


@njit(cache=True)
def _ros2_result(ka, kb, h, dx):
    a, b = 1.5 * h[0], 0.5 * h[0]
    for i in range(dx.size):
        dx[i] = ka[i] * a + b * kb[i]


@njit(cache=True)
def _ros2_error(ka, kb, h, err):
    """ROS2's embedded estimate x₊ − (x0 ⊕ h ka) = h/2 (ka + kb) (Verwer et al. 1999)."""
    a = 0.5 * h[0]
    for i in range(err.size):
        err[i] = a * (ka[i] + kb[i])


@njit(cache=True)
def _error_ratio(err, dx, x0, x1, atol, xv, rtol):
    """max_i |err_i| / (atol_i + rtol·ref_i): ref_i = max(|v|) at the step's two ends for a velocity (xv[i]
    its index in X), else the step's own change |dx_i|; inf if err holds a NaN."""
    worst = 0.0
    for i in range(err.size):
        j = xv[i]
        ref = max(abs(x0[j]), abs(x1[j])) if j >= 0 else abs(dx[i])
        r = abs(err[i]) / (atol[i] + rtol * ref)
        if not r <= worst:
            if r != r:
                return math.inf
            worst = r
    return worst


def _nothing():
    pass


def _transformed(gamma: float, alpha: np.ndarray, gam: np.ndarray, b: np.ndarray):
    """(γ, a, c, m) of the U form from the k form's α (strictly lower), γ_ij (lower, off the diagonal)
    and b."""
    G = gam + gamma * np.eye(len(b))
    Gi = np.linalg.inv(G)
    a = alpha @ Gi
    c = np.diag(np.full(len(b), 1.0 / gamma)) - Gi
    m = b @ Gi
    return gamma, np.tril(a, -1), np.tril(c, -1), m


_G = 4.3586652150845900e-01
_GAMMA_34 = np.array([[0, 0, 0, 0],                    # ROS34PW2's γ_ij (k form, off the diagonal)
                      [-8.7173304301691801e-01, 0, 0, 0],
                      [-9.0338057013044082e-01, 5.4180672388095326e-02, 0, 0],
                      [2.4212380706095346e-01, -1.2232505839045147e+00, 5.4526025533510214e-01, 0]])
ROS34PW2 = _transformed(
    _G,
    np.array([[0, 0, 0, 0],
              [8.7173304301691801e-01, 0, 0, 0],
              [8.4457060015369423e-01, -1.1299064236484185e-01, 0, 0],
              [0, 0, 1.0, 0]]),
    _GAMMA_34,
    np.array([2.4212380706095346e-01, -1.2232505839045147e+00, 1.5452602553351020e+00, _G]))
# ROS34PW2's embedded order-2 weights b̂ (Rang & Angermann 2005), as m̂ = b̂ Γ⁻¹ in the U form
_M_HAT = np.array([3.7810903145819369e-01, -9.6042292212423178e-02, 0.5, 2.1793326075422950e-01]) @ \
    np.linalg.inv(_GAMMA_34 + _G * np.eye(4))
_ALPHA = np.array([0.0, 8.7173304301691801e-01, 8.4457060015369423e-01 - 1.1299064236484185e-01, 1.0])  # stage times
GAMMA_ROS2 = 1.0 + 1.0 / np.sqrt(2.0)


class RosenbrockWParams(FixedStepParams):
    method: Literal["ros2", "ros34pw2"] = Field("ros2", description="the W-method: ros2 (robust on held robots) "
                                                                   "or ros34pw2 (more accurate while driving)")
    jacobian_every: int = Field(1, ge=1, description="steps between Jacobian assemblies (the LU is refreshed with it)")
    jacobian_refresh: Literal["steps", "on_sources"] = Field(
        "steps", description="steps: assemble every jacobian_every steps; on_sources: also at a step where a "
                             "time-driven source's output (a component with no inputs and no continuous state, "
                             "e.g. a schedule's set-points) changed since the last assembly, and at every step "
                             "for refresh_window s after it")
    refresh_window: float = Field(0.0, ge=0.0, description="s of assembly at every step after a source change "
                                                           "(jacobian_refresh: on_sources)")
    refresh_substeps: int = Field(1, ge=1, description="steps per base step at a source change and in its window "
                                                       "(jacobian_refresh: on_sources): the transient after a "
                                                       "set-point jump taken at a finer step")
    step_control: Literal["fixed", "error"] = Field(
        "error", description="fixed: substeps (and refresh_substeps) equal steps per base step; error: steps "
                             "chosen by the method's embedded error estimate against atol_q, atol_v and rtol, never "
                             "longer than the base step (which stays the control period)")
    atol_q: float = Field(3e-4, gt=0, description="m or rad: absolute tolerance on each position coordinate's "
                                                  "change over a step (step_control: error)")
    atol_v: float = Field(3e-3, gt=0, description="m/s or rad/s: absolute tolerance on each velocity "
                                                  "(step_control: error)")
    rtol: float = Field(3e-3, ge=0, description="relative tolerance: on |v| for velocities, on the step's own "
                                                "change for positions and other states (step_control: error)")
    h_min: float = Field(1e-6, gt=0, description="s: a step that would have to be shorter fails the run, naming "
                                                 "the time and the error (step_control: error)")
    h_max: float | None = Field(None, gt=0, description="s: the longest step (default: the base step)")
    error_filter: bool = Field(True, description="measure the error estimate through W⁻¹ (Shampine's filter: the "
                                                 "stiff modes the method damps do not shrink the step; one more "
                                                 "solve per step)")

    @model_validator(mode="after")
    def _substeps_are_fixed_steps(self):
        if self.step_control == "error" and (self.substeps != 1 or self.refresh_substeps != 1):
            raise ValueError(f"substeps = {self.substeps} and refresh_substeps = {self.refresh_substeps} split fixed "
                             "steps; with step_control: error the error estimate splits the base step (leave them "
                             "at 1, or set step_control: fixed)")
        return self


class RosenbrockW(FixedStep):
    name = "rosenbrock_w"
    order = 2
    description = "linearly implicit Rosenbrock W-method (ROS2, or ROS34PW2) on the components' analytic Jacobians"
    Params = RosenbrockWParams

    def _alloc(self, nx, ndx):
        """Work arrays, the linearisation and every bound call, made once per system (a session's runs and
        restarts reuse them, and with them the solves bound per factorisation); then this run's state."""
        if getattr(self, "_built_for", None) is not self.sys:
            self._build(nx, ndx)
            self._built_for = self.sys
        self.h_lu = None
        self.age = 0
        self._burst_until = -np.inf
        self._event = False
        self._t_left = math.inf                 # stage times are kept below it (error control: the base step's end)
        self.level = 0                          # error control: the base step in 2^level steps (carried over)
        self._stale = False                     # error control: J is not from the step's start
        self.stats.update(jacobians=0, source_refreshes=0)
        if self.p.step_control == "error":
            self.stats.update(rejected=0, h_smallest=math.inf)

    def _build(self, nx, ndx):
        sys = self.sys
        self.lin = Linearization(sys)
        self.lin.gamma_hint = GAMMA_ROS2 if self.p.method == "ros2" else ROS34PW2[0]
        self.x0 = np.zeros(nx)
        self.f1 = np.zeros(ndx)
        self.U = np.zeros((4, ndx))
        self.rhs = np.zeros(ndx)
        self.dx = np.zeros(ndx)
        # a stage's state goes straight into the plan's X (x0 keeps the step's start), as does the result
        self._to_x = sys.bind_integrate(self.x0, self.dx, sys.X)
        self._dexp_inv = sys.bind_dexp_inv(self.x0, self.dx, self.f1)
        # the solves on these work arrays, bound once per factorisation change (Linearization.bind_solve)
        self._solve_k1 = self.lin.bind_solve(sys.DX, self.U[0])      # the simulator's k1 is sys.DX
        self._solve_f1 = self.lin.bind_solve(self.f1, self.U[1])
        self._solve_rhs = tuple(self.lin.bind_solve(self.rhs, self.U[i]) for i in range(4))
        self.gamma = GAMMA_ROS2 if self.p.method == "ros2" else ROS34PW2[0]
        self.h = np.zeros(1)
        ka, kb = self.U[0], self.U[1]
        self._offset = bind(_ros2_offset, ka, self.h, self.dx)
        self._rhs2 = bind(_ros2_rhs, self.f1, ka)
        self._result = bind(_ros2_result, ka, kb, self.h, self.dx)
        self._watched = self._sources() if self.p.jacobian_refresh == "on_sources" else ()
        # W is refactorised when h moves beyond float noise (t1 − t0 differs from dt in the last bits; a W-method
        # keeps its order with any matrix, so W from an h equal to round-off costs nothing in consistency)
        self._refactor = 1e-9
        if self.p.step_control == "error":
            self._alloc_error_control(ndx)

    def _alloc_error_control(self, ndx):
        """The embedded estimate's work arrays and each tangent coordinate's tolerance: atol_v on the
        velocities of second-order states (rtol on |v|), atol_q on positions and every other state (rtol
        on the step's change)."""
        sys = self.sys
        self.err, self.err_w, self.k1s = np.zeros(ndx), np.zeros(ndx), np.zeros(ndx)
        self.atol = np.full(ndx, self.p.atol_q)
        self.xv = np.full(ndx, -1, dtype=np.int64)
        for s in sys.slices:
            if s.second_order:
                nv = s.second_order
                v = slice(s.dx.start + nv, s.dx.start + 2 * nv)
                self.atol[v] = self.p.atol_v
                self.xv[v] = np.arange(s.x.stop - nv, s.x.stop)
        # Shampine's filter: W⁻¹·err, so that the stiff components the method damps do not shrink the step
        if self.p.error_filter:
            self._solve_err = self.lin.bind_solve(self.err, self.err_w)
        else:
            self.err_w = self.err
            self._solve_err = _nothing
        self._ros2_err = bind(_ros2_error, self.U[0], self.U[1], self.h, self.err)
        self._ratio = bind(_error_ratio, self.err_w, self.dx, self.x0, sys.X, self.atol, self.xv, float(self.p.rtol))

    def _sources(self):
        """(live, copy) of each numeric output read in the plan whose component has no inputs and no continuous
        state: a function of time and discrete state only (schedules, sampled sources), whose jump is an
        event the stiff terms answer (a screw set-point: the friction's slip regime changes)."""
        plan = self.sys
        stateful = {s.comp.name for s in plan.slices}
        out = []
        for ref in dict.fromkeys(plan.sources.values()):
            comp = plan.components[ref.comp]
            if ref.comp in stateful or comp.inputs:
                continue
            live = getattr(plan.io[ref.comp][2], ref.port, None)
            if isinstance(live, np.ndarray) and live.dtype == np.float64:
                live = live.reshape(-1)
                out.append((live, live.copy()))
        return tuple(out)

    def _source_event(self, t, first: bool) -> bool:
        """A watched source changed since the last step (its copies updated), or the refresh window is
        open; at a run's first step the copies are only taken."""
        hit = False
        for live, seen in self._watched:
            hit |= _changed(live, seen)
        if hit and not first:
            self.stats["source_refreshes"] += 1
            self._burst_until = t + self.p.refresh_window
            return True
        return t < self._burst_until

    def substeps_now(self, t0):
        self._event = bool(self._watched) and self._source_event(t0, self.h_lu is None)
        return self.p.substeps * (self.p.refresh_substeps if self._event else 1)

    def advance(self, t0, t1, k1):
        if self.p.step_control == "fixed":
            return super().advance(t0, t1, k1)
        self._advance_controlled(t0, t1, k1)

    def _advance_controlled(self, t0, t1, k1):
        """The base step t0 → t1 in 2^level equal steps, the level set by the embedded error estimate
        (Hairer & Wanner II, IV.8, on a ladder of halvings): a step whose error ratio e exceeds 1 is taken
        again from its start at the level that 0.9 e^−½ asks for (with a Jacobian assembled there if the one
        in use is older); an accepted one lets the level drop (the step double) as far as min(5, 0.9 e^−½)
        allows where the step's end sits on the coarser grid. The level carries over base steps. Steps of
        span/2^level land on t1 exactly, never cross it (records, stops and controllers see the instants of
        fixed steps), and revisit a few step sizes, whose factorisations' bound solves are kept."""
        sys, p = self.sys, self.p
        span = t1 - t0
        top = self._top_level(span)
        level = max(self.level, top)
        self._event = bool(self._watched) and self._source_event(t0, self.h_lu is None)
        self._t_left = np.nextafter(t1, -math.inf)
        j, first = 0, True                       # steps of span/2^level done
        while j < (1 << level):
            h = span / (1 << level)
            t = t0 + j * h
            if not first:
                k1 = sys.f(t, sys.X)             # the plan at the step's start: a Jacobian assembled now is there
                self.stats["f_evals"] += 1
            first = False
            np.copyto(self.k1s, k1)
            while True:
                self.step(t, h, k1)
                e = self._error()
                if e <= 1.0:
                    break
                self.stats["rejected"] += 1
                np.copyto(sys.X, self.x0)
                down = max(1, math.ceil(math.log2(math.sqrt(e) / 0.9))) if e < math.inf else 3
                level += min(down, 3)
                j <<= min(down, 3)
                h = span / (1 << level)
                if h < p.h_min:
                    raise SnakesimError(f"rosenbrock_w: the step fell below h_min = {p.h_min:g} s at t = {t:.9g} s "
                                        f"(error ratio {e:.3g} against atol_q = {p.atol_q:g}, atol_v = {p.atol_v:g}, "
                                        f"rtol = {p.rtol:g}); loosen the tolerances or lower h_min")
                if self._stale:                  # retry with J at this step's start: f there again
                    k1 = sys.f(t, sys.X)
                    self.stats["f_evals"] += 1
                    self.h_lu = None
                else:
                    np.copyto(sys.DX, self.k1s)
                    k1 = sys.DX
            j += 1
            self.stats["steps"] += 1
            self.stats["h_smallest"] = min(self.stats["h_smallest"], h)
            grow = min(5.0, 0.9 / math.sqrt(e)) if e > 0.0 else 5.0
            while grow >= 2.0 and level > top and not j & 1:
                level -= 1
                j >>= 1
                grow *= 0.5
        self.level = level

    def _top_level(self, span: float) -> int:
        """The coarsest level: 0 (the base step), or the first whose step is within h_max."""
        level = 0
        while self.p.h_max is not None and span / (1 << level) > self.p.h_max * (1 + 1e-12):
            level += 1
        return level

    def _error(self) -> float:
        """The accepted-or-not ratio of the step just taken: its embedded estimate (in self.err), filtered by
        W⁻¹, against the tolerances; > 1 rejects."""
        if self.p.method == "ros2":
            self._ros2_err()
        else:
            np.dot(ROS34PW2[3] - _M_HAT, self.U, out=self.err)
        self._solve_err()
        return self._ratio()

    def step(self, t, h, k1):
        sys, lin = self.sys, self.lin
        np.copyto(self.x0, sys.X)
        if self.h_lu is None or self.age >= self.p.jacobian_every or self._event:
            lin.assemble(t)                 # the plan was just evaluated at (t, x0): k1 is f there
            self.stats["jacobians"] += 1
            self.age = 0
            self.h_lu = None
        self._stale = self.age > 0
        if self.h_lu is None or abs(h - self.h_lu) > self._refactor * self.h_lu:
            lin.factor(self.gamma * h)
            self.h_lu = h
        self.age += 1
        if self.p.method == "ros2":
            self._ros2(t, h, k1)
        else:
            self._ros34pw2(t, h, k1)

    def _stage_slope(self, t, u=None):
        """f at x0 ⊕ u, in the chart at x0, into self.f1 (u None: already in self.dx). Under error control a
        stage at the base step's end is evaluated just before it (``_t_left``): a time-driven source that
        switches at a base instant (a schedule, a gait's start) belongs to the next base step, as its major
        pass there says, and is not a discontinuity inside this one that no step is short enough to resolve."""
        sys = self.sys
        if u is not None:
            np.copyto(self.dx, u)
        self._to_x()
        np.copyto(self.f1, sys.f(min(t, self._t_left), sys.X))
        self._dexp_inv()
        self.stats["f_evals"] += 1
        return self.f1

    def _ros34pw2(self, t, h, k1):
        gamma, a, c, m = ROS34PW2
        U, gh, rhs = self.U, gamma * h, self.rhs
        for i in range(4):
            if i == 0:
                np.multiply(k1, gh, out=rhs)
            else:
                u = a[i, 0] * U[0]
                for j in range(1, i):
                    u += a[i, j] * U[j]
                f = self._stage_slope(t + h * _ALPHA[i], u)
                np.multiply(f, gh, out=rhs)
                for j in range(i):
                    rhs += (gamma * c[i, j]) * U[j]
            self._solve_rhs[i]()
        np.multiply(U[0], m[0], out=self.dx)
        for i in range(1, 4):
            self.dx += m[i] * U[i]
        self._to_x()

    def _ros2(self, t, h, k1):
        if k1 is self.sys.DX:
            self._solve_k1()                        # ka
        else:
            self.lin.solve(k1, self.U[0])
        self.h[0] = h
        self._offset()                              # dx = h ka: the stage's offset
        self._stage_slope(t + h)                    # f1 = f(x0 ⊕ dx) in the chart at x0
        self._rhs2()                                # f1 −= 2 ka
        self._solve_f1()                            # kb
        self._result()                              # dx = 3/2 h ka + 1/2 h kb
        self._to_x()

