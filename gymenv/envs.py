"""The registered environments: ``snakesim/ScrewTraverse-v0`` and ``snakesim/MiniEelsCrawl-v0``.

Each is a :class:`~.env.SnakesimEnv` over a shipped scene with its observation, action, reward and
dispersions chosen here; every keyword of :class:`~.env.SnakesimEnv` may be given to
``gymnasium.make`` to change them (``gymnasium.make("snakesim/ScrewTraverse-v0", dispersions=None)``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .env import Act, Obs, SnakesimEnv, progress

HERE = Path(__file__).resolve().parent
POSE = Obs(low=[-100.0, -100.0, -np.pi], high=[100.0, 100.0, np.pi])     # x, y (m), yaw (rad)


class ScrewTraverseEnv(SnakesimEnv):
    """EELS 1.0 (10 modules) on flat ice, in the default scene's crescent (``surface-screw-traverse``).

    - action (10): the speed set-points of the 10 screw pairs, −5 .. 5 rad/s (normalised to −1 .. 1;
      a pair's rear screw turns at −speed), fed to the joint PID; the bends and twists hold the scene's
      crescent (the scene's schedule's set-points, ``phases.setpoint``);
    - observation (33): the tail's planar pose (x, y in m, yaw in rad) and the 30 DOF joint rates (rad/s);
    - reward: metres the tail moved along +x in the step (the crescent's chord: all screws forward drive
      it there);
    - 0.1 s a step (5 base steps of the scene's 20 ms), 10 s an episode (100 steps); terminated by the
      scene's stop (the tail left the ground: contact blew up) or any other end of the run;
    - dispersions (``dispersions/screw-traverse.yaml``): the screws' thread anisotropy ‖e_v‖ and the
      crescent's bend, uniform.
    """

    def __init__(self, **kw):
        defaults = dict(
            observation={"tail_pose.pose": POSE, "robot.joint_v": Obs(-50.0, 50.0)},
            action={"pid.setpoint": Act(-5.0, 5.0, elements="screw_*", rest="phases.setpoint")},
            reward=progress("tail_pose.pose", 0),
            control_period=0.1, episode_seconds=10.0,
            dispersions=HERE / "dispersions" / "screw-traverse.yaml")
        super().__init__(kw.pop("scene", "surface-screw-traverse"), **{**defaults, **kw})


class MiniEelsCrawlEnv(SnakesimEnv):
    """Mini EELS (10 modules, bend joints only) crawling on flat ice by lateral undulation
    (``mini-eels-crawl``).

    - action (2): the serpenoid gait's amplitude, 0 .. 1 rad, and frequency, 0 .. 1 Hz (normalised
      to −1 .. 1), the gait's open command inputs;
    - observation (23): the tail's planar pose, the 10 bend angles (rad) and rates (rad/s);
    - reward: metres the centre of mass moved along −x in the step (the wave runs tail to head, so the
      robot crawls tail first);
    - 0.1 s a step (200 base steps of the scene's 0.5 ms), 5 s an episode (50 steps); terminated by
      the scene's stop (the robot left the ground) or any other end of the run;
    - dispersions (``dispersions/mini-eels-crawl.yaml``): the skin's friction along and across.
    """

    def __init__(self, **kw):
        defaults = dict(
            observation={"tail_pose.pose": POSE, "robot.joint_q": Obs(-np.pi, np.pi),
                         "robot.joint_v": Obs(-50.0, 50.0)},
            action={"gait.amplitude": Act(0.0, 1.0), "gait.frequency": Act(0.0, 1.0)},
            signals=["robot.com"],
            reward=progress("robot.com", 0, scale=-1.0),
            control_period=0.1, episode_seconds=5.0,
            dispersions=HERE / "dispersions" / "mini-eels-crawl.yaml")
        super().__init__(kw.pop("scene", "mini-eels-crawl"), **{**defaults, **kw})


#: id -> entry point (module:class)
ENVS = {
    "snakesim/ScrewTraverse-v0": "snakesim.gym.envs:ScrewTraverseEnv",
    "snakesim/MiniEelsCrawl-v0": "snakesim.gym.envs:MiniEelsCrawlEnv",
}


def register_envs() -> None:
    """Register the ids with Gymnasium (once: a second call changes nothing). Called when
    ``snakesim.gym`` is imported, and by Gymnasium 0.26-0.29's plugin loader through the
    ``gymnasium.envs`` entry point."""
    from gymnasium.envs.registration import register, registry

    for env_id, entry_point in ENVS.items():
        if env_id not in registry:
            register(id=env_id, entry_point=entry_point)
