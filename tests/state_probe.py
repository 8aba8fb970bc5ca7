"""A probe component that snapshots the plan's whole state (X, XD) at every output pass: the state-edit tests
(tests/framework/test_state_edit.py) and the /sim requests over ROS 2 (tests/ros2/test_sim_requests.py)
compare the state itself. The test hands the probe's cache the plan: ``plan.caches["probe"].plan = plan``."""

from __future__ import annotations

import dataclasses

from snakesim.framework import Component, Output, Params


@dataclasses.dataclass
class ProbeRun:
    plan: object = None
    seen: list = dataclasses.field(default_factory=list)    # (t, X copy, XD copy) at each output pass


class StateProbe(Component[Params]):
    """A sink whose output() snapshots the plan's X and XD (once the test has handed it the plan)."""

    type_name = "test_state_probe"
    is_sink = True
    t_seen = Output(unit="s", feedthrough=())

    def make_cache(self, x, u, y):
        return ProbeRun()

    def output(self, t, x, u, y):
        run = u.cache
        if run.plan is not None:
            run.seen.append((t, run.plan.X.copy(), run.plan.XD.copy()))
        y.t_seen[...] = t

    def update(self, t, xd, u):
        pass
