"""Path following for EELS 1.0 on its side: screw speeds for thrust, bend joints for heading.

The robot lies on its side (bend axes vertical: bend joints yaw). Counter-rotating screw pairs push
it along its body, but on ice every pair also leaves a yaw couple, so with a straight body the robot
curves to the right (about −0.15 rad/s at 8 rad/s screw speed, 0.17 m/s; measured in this scene).
What steers it is the body's shape: bending the middle joints (``steer_joints``) to the left makes
a V whose two halves push outward, and that turns it left; about ``trim`` rad per joint cancels the
drift (ω ≈ 0.27 rad/s per rad of bend, from the same runs). The V is wide (its apex ~1.4 m off the
line from tail to head: plan with that clearance), and changing it shifts the whole body sideways
(forming it from straight moves the head ~1 m), so the bend changes slowly and within a narrow
band. The law is pure pursuit on the body's heading, the direction from tail to head (which is the
direction it moves in, whatever the V):

    target   the path point ``lookahead`` m beyond the one nearest the head
    e        = wrap(atan2(target − head) − atan2(head − tail))          rad
    bend     → clip(trim + kp·e + ki·∫e dt, bend_min, bend_max)         rad, on each steer joint,
               at most bend_rate rad/s, from a straight body at the start (its tightest right turn)
    screws   = speed (rad/s of each front screw; its rear screw is the URDF mimic at −speed)

Other joints (twists, the bends not steering) hold 0. Units: m, rad, s, world frame.
"""

from dataclasses import dataclass

import numpy as np


@dataclass
class FollowerParams:
    speed: float = 10.0                    # rad/s, every front screw
    steer_joints: tuple = ("bend_03", "bend_04", "bend_05", "bend_06")
    trim: float = 0.5                      # rad per steer joint that drives straight
    kp: float = 0.8                        # rad of bend per rad of heading error
    ki: float = 0.1                        # rad of bend per rad·s
    bend_min: float = 0.0                  # rad: the straight body already turns right (radius ~1.3 m)
    bend_max: float = 0.6                  # rad: 4 × 0.8 folds the body (head arm back beside the tail)
    lookahead: float = 1.2                 # m
    bend_rate: float = 0.3                 # rad/s: the bend moves at most this fast (a fast bend swings the body)


def wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def pursuit_target(path: np.ndarray, head: np.ndarray, lookahead: float) -> np.ndarray:
    """The point ``lookahead`` m along the path past the path point nearest the head (its end if shorter)."""
    near = int(np.argmin(np.linalg.norm(path - head, axis=1)))
    seg = np.linalg.norm(np.diff(path[near:], axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    k = int(np.searchsorted(s, lookahead))
    return path[min(near + k, len(path) - 1)]


class Follower:
    """Joint set-points from the head and tail positions and the planned path (state: the error integral)."""

    def __init__(self, joints: list[str], p: FollowerParams = FollowerParams()):
        self.p = p
        self.joints = list(joints)
        self.screw = np.array([n.startswith("screw") for n in self.joints])
        self.steer = np.array([n in p.steer_joints for n in self.joints])
        missing = set(p.steer_joints) - set(self.joints)
        if missing:
            raise ValueError(f"steer joints {sorted(missing)} are not among the robot's joints {self.joints}")
        self.integral = 0.0
        self.bend = 0.0                    # rad on each steer joint, now

    def command(self, head, tail, path: np.ndarray, dt: float, stop: bool = False):
        """(position[n], velocity[n]) for ``self.joints``: screws by velocity, the rest by position."""
        p = self.p
        goal = self.bend                           # stopped: the shape holds (straight at the start)
        moving = not stop and path is not None and len(path) > 1
        if moving:
            head, tail = np.asarray(head, dtype=float)[:2], np.asarray(tail, dtype=float)[:2]
            target = pursuit_target(path, head, p.lookahead)
            d, b = target - head, head - tail
            e = float(wrap(np.arctan2(d[1], d[0]) - np.arctan2(b[1], b[0])))
            raw = p.trim + p.kp * e + p.ki * self.integral
            if p.bend_min < raw < p.bend_max or np.sign(e) != np.sign(raw - p.trim):
                self.integral += e * dt            # no wind-up against the limits
            goal = float(np.clip(raw, p.bend_min, p.bend_max))
        self.bend += float(np.clip(goal - self.bend, -p.bend_rate * dt, p.bend_rate * dt))
        position = np.where(self.steer, self.bend, 0.0)
        velocity = np.where(self.screw, p.speed if moving else 0.0, 0.0)
        return position, velocity
