"""Joint set-points replayed from a CSV file (recorded hardware joint positions/velocities, paper 4.2).

File format: a header ``time,<joint>,<joint>,...`` (DOF joint names of the
robot, any subset, any order), then one row per knot: time in s, strictly
increasing, and finite values (rad for position-mode joints, rad/s for
velocity-mode ones). Joints the file does not name take ``default`` (by
name/pattern, 0 otherwise). Outside [t_first, t_last] the end values hold.

    linear: y(t) = (1 − w)·Y_k + w·Y_{k+1},  w = (t − t_k)/(t_{k+1} − t_k)   exact at the knots
    cubic:  not-a-knot cubic spline through the knots (scipy CubicSpline), C² between them

out  setpoint[nj]  joints in the multibody's order
     rate[nj]      rad/s, dy/dt of the interpolant (0 outside the time range)
uses robot: RobotModel (the multibody's): the DOF joint names the file's columns must be

A relative ``file`` is looked up from the working directory, then from the
repository root (so ``configs/trajectories/...`` works from anywhere). Every
bad file is a ValueError naming the file, the line/column and what is valid.
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import Field

from snakesim.components.csv_numbers import finite_number
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework import Component, Params, Uses

from .joint_selection import finite_or_raise, per_joint
from .setpoint_ports import setpoint_outputs

REPO_ROOT = Path(__file__).resolve().parents[2]


class CsvTrajectoryParams(Params):
    file: str = Field(..., description="CSV path: header time,<joint names>; one row per knot")
    interpolation: Literal["linear", "cubic"] = "linear"
    default: dict[str, float] = Field(default_factory=dict, description="value of joints the file omits, by name/pattern")


def find_file(name: str) -> Path:
    path = Path(name).expanduser()
    for cand in ([path] if path.is_absolute() else [Path.cwd() / path, REPO_ROOT / path]):
        if cand.is_file():
            return cand
    raise ValueError(f"trajectory file '{name}' not found (looked in {Path.cwd()} and {REPO_ROOT})")


def read_trajectory(name: str, joints) -> tuple[np.ndarray, list[str], np.ndarray]:
    """(times[m], column joint names, values[m, ncol]) of a trajectory CSV, validated."""
    path = find_file(name)
    with path.open(newline="") as fh:
        rows = [(i + 1, r) for i, r in enumerate(csv.reader(fh)) if r and any(c.strip() for c in r)]
    if not rows:
        raise ValueError(f"{path}: empty file; expected a header 'time,<joint>,...' and at least one row")
    line, header = rows[0]
    header = [h.strip() for h in header]
    if header[0] != "time":
        raise ValueError(f"{path}:{line}: the first column must be 'time', got '{header[0]}'")
    cols = header[1:]
    if not cols:
        raise ValueError(f"{path}:{line}: no joint columns after 'time'; joints: {', '.join(joints)}")
    unknown = [c for c in cols if c not in joints]
    if unknown:
        raise ValueError(f"{path}:{line}: unknown joint name(s) {unknown}; valid DOF joints: {', '.join(joints)}")
    dup = sorted({c for c in cols if cols.count(c) > 1})
    if dup:
        raise ValueError(f"{path}:{line}: joint column(s) {dup} appear more than once")
    if len(rows) < 2:
        raise ValueError(f"{path}: no data rows after the header")
    data = np.empty((len(rows) - 1, len(header)))
    for k, (ln, r) in enumerate(rows[1:]):
        if len(r) != len(header):
            raise ValueError(f"{path}:{ln}: {len(r)} fields, the header has {len(header)}")
        for j, cell in enumerate(r):
            data[k, j] = finite_number(cell, f"{path}:{ln}: column '{header[j]}'")
    t = data[:, 0]
    dt = np.diff(t)
    if (dt <= 0).any():
        k = int(np.flatnonzero(dt <= 0)[0])
        raise ValueError(f"{path}:{rows[k + 2][0]}: time {t[k + 1]:g} s does not increase past {t[k]:g} s "
                         "(times must increase strictly)")
    return t, cols, data[:, 1:]


class CsvTrajectory(Component[CsvTrajectoryParams]):
    type_name = "csv_trajectory"
    robot = Uses(RobotModel)
    setpoint, rate = setpoint_outputs()

    def setup(self):
        p = self.p
        names = list(self.robot.joints)
        finite_or_raise(p.default, f"{self.name}: default")
        try:
            t, cols, Y = read_trajectory(p.file, names)
        except ValueError as e:
            raise ValueError(f"{self.name}: {e}") from None
        self._base = np.array(per_joint(names, p.default, f"{self.name}: default", 0.0), dtype=float)
        self._cols = np.array([self.robot.dof_index(c) for c in cols], dtype=np.int64)
        self._t, self._Y = t, Y
        self._spline = self._dspline = None
        if p.interpolation == "cubic" and t.size >= 2:
            from scipy.interpolate import CubicSpline

            self._spline = CubicSpline(t, Y, axis=0, bc_type="not-a-knot" if t.size > 3 else "natural")
            self._dspline = self._spline.derivative()

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(values[ncol], rates[ncol]) of the file's columns at time t."""
        ts, Y = self._t, self._Y
        if ts.size == 1 or t <= ts[0]:
            return Y[0], np.zeros(Y.shape[1])
        if t >= ts[-1]:
            return Y[-1], np.zeros(Y.shape[1])
        if self._spline is not None:
            return self._spline(t), self._dspline(t)
        k = int(np.searchsorted(ts, t, side="right")) - 1
        h = ts[k + 1] - ts[k]
        w = (t - ts[k]) / h
        return (1.0 - w) * Y[k] + w * Y[k + 1], (Y[k + 1] - Y[k]) / h

    def output(self, t, x, u, y):
        val, rate = self.sample(t)
        y.setpoint[:] = self._base
        y.setpoint[self._cols] = val
        y.rate[:] = 0.0
        y.rate[self._cols] = rate
