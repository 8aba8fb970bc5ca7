"""examples/autonomy end to end: `snakesim run perception-obstacle-course` in lockstep beside the autonomy node,
two processes on a private ROS 2 domain on loopback.

What is checked against what the node cannot bend: the head's end position and every link's track come
from the sim's own recording (--out signals.csv: robot.link_poses), the obstacles from
terrains/obstacle-course.yaml (the node never reads it: its map is built from the lidar), and the node is
run with snakesim made unimportable. Lockstep: the node answers every control period from t = 0 without a
gap, each answer stamped with the state it answers (a multiple of the 10 ms period), and every /clock it
saw was at most one period past its last answer.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
NODE = ROOT / "examples" / "autonomy" / "node.py"
TERRAIN = ROOT / "terrains" / "obstacle-course.yaml"
SNAKESIM = Path(sys.executable).with_name("snakesim")
XML = ('<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface address="127.0.0.1"/></Interfaces>'
       '<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>'
       '<MaxAutoParticipantIndex>32</MaxAutoParticipantIndex><Peers><Peer address="127.0.0.1"/></Peers>'
       '</Discovery></Domain></CycloneDDS>')
GOAL, GOAL_RADIUS = (9.0, -2.7), 0.6     # m: past the course (x in [1, 8])
PERIOD = 0.01                            # s, the control period lockstep holds at
ROBOT_RADIUS = 0.09                      # m, the screws' envelope (the scene's base height 0.0898 m)

#: the node run with snakesim unimportable: any import of it fails the run
BLOCKED = ("import runpy, sys\n"
           "class Block:\n"
           "    def find_spec(self, name, path=None, target=None):\n"
           "        if name == 'snakesim' or name.startswith('snakesim.'):\n"
           "            raise ImportError('the autonomy node imported ' + name)\n"
           "sys.meta_path.insert(0, Block())\n"
           "sys.argv = sys.argv[1:]\n"
           "runpy.run_path(sys.argv[0], run_name='__main__')\n"
           "assert not any(m == 'snakesim' or m.startswith('snakesim.') for m in sys.modules)\n")


def box_distance(p: np.ndarray, center, size, yaw: float) -> np.ndarray:
    """Signed distance (m) from points p [..., 3] to a box (centre, full edges, yaw about z)."""
    d = p - np.asarray(center, dtype=float)
    c, s = np.cos(yaw), np.sin(yaw)
    local = np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1], d[..., 2]], -1)
    q = np.abs(local) - np.asarray(size, dtype=float) / 2
    return np.linalg.norm(np.maximum(q, 0.0), axis=-1) + np.minimum(q.max(-1), 0.0)


def obstacle_distance(p: np.ndarray) -> np.ndarray:
    """Distance (m) from points p [..., 3] to the nearest block or rock of the course."""
    course = yaml.safe_load(TERRAIN.read_text())
    d = [box_distance(p, b["center"], b["size"], b["yaw"]) for b in course["boxes"]]
    d += [np.linalg.norm(p - np.asarray(s["center"]), axis=-1) - s["radius"] for s in course["spheres"]]
    return np.min(d, axis=0)


def test_obstacle_distance_is_exact_on_simple_points():
    # independent of the run: a point 0.1 m above the first block's top, one 0.05 m outside a rock
    course = yaml.safe_load(TERRAIN.read_text())
    b, s = course["boxes"][0], course["spheres"][0]
    top = np.array(b["center"]) + [0, 0, b["size"][2] / 2 + 0.1]
    side = np.array(s["center"]) + [s["radius"] + 0.05, 0, 0]
    assert box_distance(top, b["center"], b["size"], b["yaw"]) == pytest.approx(0.1)
    assert obstacle_distance(side[None])[0] == pytest.approx(0.05)


@pytest.mark.slow
def test_the_node_reaches_the_goal_past_the_course_in_lockstep_without_touching_an_obstacle(tmp_path):
    pytest.importorskip("cyclonedds.domain")
    domain = 40 + os.getpid() % 50
    env = {**os.environ, "ROS_DOMAIN_ID": str(domain), "CYCLONEDDS_URI": XML, "PYTHONUNBUFFERED": "1"}
    env.pop("PYTHONPATH", None)
    log, picture, out = tmp_path / "node.json", tmp_path / "run.png", tmp_path / "out"
    node = subprocess.Popen([sys.executable, "-c", BLOCKED, str(NODE), "--goal", *map(str, GOAL),
                             "--goal-radius", str(GOAL_RADIUS - 0.2), "--log", str(log), "--picture", str(picture),
                             "--timeout", "500"], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        sim = subprocess.run(
            [str(SNAKESIM), "run", "perception-obstacle-course", "--ros2-commands", "--ros2-lockstep",
             "--ros2-hold-timeout", "5", "--odometry", "head", "--ros2-rate", "tf=10",
             "--set", "camera_rate=0.5", "--set", "components.stereo.params.width=16",
             "--set", "components.stereo.params.height=12",
             "--set", "record=[tail_pose.pose, robot.link_poses]", "--duration", "80", "--quiet", "--out", str(out)],
            env=env, capture_output=True, text=True, timeout=600)
        node_out, node_err = node.communicate(timeout=60)
    finally:
        if node.poll() is None:
            node.kill()
            node.wait()
    assert node.returncode == 0, node_err[-3000:]
    summary = json.loads((out / "summary.json").read_text())
    # the node leaves once it has arrived; the sim then holds until its hold timeout ends the run
    assert "hold_timeout" in summary["stop_reason"], (summary["stop_reason"], sim.stderr[-2000:])
    result = json.loads(log.read_text())
    assert result["reached"], node_out

    header = (out / "signals.csv").read_text().split("\n", 1)[0].split(",")
    rows = np.loadtxt(out / "signals.csv", delimiter=",", skiprows=1, ndmin=2)
    col = {name: i for i, name in enumerate(header)}
    links = [n[len("robot.link_poses."):-2] for n in header if n.startswith("robot.link_poses.") and n.endswith(".x")]
    xyz = np.stack([rows[:, [col[f"robot.link_poses.{ln}.{c}"] for c in "xyz"]] for ln in links], 1)
    head = xyz[-1, links.index("head"), :2]
    assert np.hypot(*(head - GOAL)) < GOAL_RADIUS, head

    # never touched an obstacle: every link origin (on the body's axis) at least the screws' radius away
    clearance = obstacle_distance(xyz)
    assert clearance.min() >= ROBOT_RADIUS, (clearance.min(), np.unravel_index(clearance.argmin(), clearance.shape))

    # lockstep: an answer for every control period from t = 0, each to a state the sim published
    answered = np.array(result["answered"])
    assert answered[0] == 0.0 and np.allclose(np.diff(answered), PERIOD, atol=1e-9), answered[:10]
    assert np.allclose(answered / PERIOD, np.round(answered / PERIOD), atol=1e-6)
    assert answered[-1] >= result["reached_at"] and summary["sim_time_s"] <= answered[-1] + 2 * PERIOD
    clock = np.array([c for c in result["clock_vs_answer"] if np.isfinite(c[1])])
    assert len(clock) > 100 and (clock[:, 0] - clock[:, 1]).max() <= PERIOD + 1e-6

    # the map is the lidar's: its obstacle cells lie on the course's obstacles (within 3 cells: all of them in
    # four runs; 84-92 % before the node deskewed the clouds, a turning head smearing blocks 15-35 cm), and it
    # holds every obstacle the lidar showed it up close. Which those were comes from the clouds' ground-truth
    # labels (the node logs, per mapped scan, each obstacle with >= 10 returns clear of the ice and their
    # nearest range): a distance to the track alone cannot say, as the robot's path varies with the timing of
    # the clouds between runs and an obstacle 2.9 m from it may hide behind a nearer one. Shown up close: in
    # >= 5 scans within 3 m (the map needs a step within 35 cm and 2 scans; ring spacing grows with range)
    cells = np.array(result["obstacles"])
    on_ground = np.column_stack([cells, np.full(len(cells), 0.02)])
    assert (obstacle_distance(on_ground) < 0.15).mean() > 0.95
    course = yaml.safe_load(TERRAIN.read_text())
    mapped = [box_distance(on_ground, o["center"], o["size"], o["yaw"]).min() for o in course["boxes"]]
    mapped += [(np.linalg.norm(on_ground - o["center"], axis=-1) - o["radius"]).min() for o in course["spheres"]]
    shown = [int(label) - 2000 for label, ranges in result["evidence"].items()
             if (np.array(ranges) < 3.0).sum() >= 5]
    assert len(shown) >= 6 and all(mapped[i] < 0.1 for i in shown), [(i, mapped[i]) for i in shown]
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
