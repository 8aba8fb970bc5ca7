"""``snakesim replay RUN_DIR``: a finished ``--out`` folder as a rerun recording, without re-simulating.

Reads ``config.yaml`` (the resolved configuration) and ``signals.csv``:

- robot: the component that provides the RobotModel (``Provides(RobotModel)``,
  the multibody), built from its params; its robot's links and URDF visuals
  (``robot.derived(link_meshes)``), exactly as the live sink draws them;
- link poses, in order of preference: the recorded ``<robot>.link_poses``
  columns; forward kinematics of recorded ``<robot>.q`` through that built
  component; otherwise its initial pose only (with a note);
- terrain: the component with a Terrain output, built from its params;
- tethers: straight ropes from a tethers component's params and the poses;
- one plot per recorded signal, every row of every column; the real-time
  factor is the run's average from ``summary.json``.

The entities are those of a live ``--viz`` recording (:mod:`.entities`);
contacts and tethers are not in signals.csv (structured signals are not
recorded), so a replay has none; tethers given as a structured signal
rather than as tethers params are not replayed either.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import yaml

from snakesim.framework import SnakesimError
from snakesim.framework.harness import Harness
from snakesim.framework.run_files import INCOMPLETE
from snakesim.framework.signals import Structured

from . import entities as E
from .attach import provides_robot, tether_lines
from .robot_geometry import link_meshes
from .sink import RerunSinkParams, robot_visuals
from .target import VizTarget, open_recording

POSE_FIELDS = ("x", "y", "z", "qx", "qy", "qz", "qw")


@dataclasses.dataclass
class ReplayReport:
    target: VizTarget
    frames: int
    series: list[str]
    notes: list[str]


def read_signals(path: Path) -> tuple[list[str], np.ndarray]:
    with open(path) as fh:
        header = fh.readline().strip()
    columns = header.split(",")
    if not columns or columns[0] != "t":
        raise SnakesimError(f"{path}: first line must be the column header starting with 't', got '{header[:60]}'")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    if data.shape[0] == 0:
        raise SnakesimError(f"{path}: no rows to replay")
    if data.shape[1] != len(columns):
        raise SnakesimError(f"{path}: {data.shape[1]} values per row but {len(columns)} column names")
    return columns, data


def signal_columns(columns: list[str], ref: str) -> tuple[list[int], list[str]]:
    """Column indices of recorded signal ``ref`` ('comp.port') and their element names."""
    idx, names = [], []
    for i, c in enumerate(columns):
        if c == ref:
            idx.append(i)
            names.append(ref.rpartition(".")[2])
        elif c.startswith(ref + ".") or c.startswith(ref + "["):
            idx.append(i)
            names.append(c[len(ref) + (1 if c[len(ref)] == "." else 0):])
    return idx, names


def load_run(run_dir: Path) -> tuple[dict, list[str], np.ndarray, dict]:
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise SnakesimError(f"'{run_dir}' is not a folder; replay reads what `snakesim run --out DIR` writes")
    need = [run_dir / "config.yaml", run_dir / "signals.csv"]
    missing = [p.name for p in need if not p.is_file()]
    if missing:
        raise SnakesimError(f"{run_dir}: no {' or '.join(missing)}; replay reads what `snakesim run --out DIR` "
                            "writes (signals.csv, summary.json, config.yaml)")
    try:
        cfg = yaml.safe_load(need[0].read_text())
    except yaml.YAMLError as e:
        raise SnakesimError(f"{need[0]}: not YAML ({e})") from None
    if not isinstance(cfg, dict) or not isinstance(cfg.get("components"), dict):
        raise SnakesimError(f"{need[0]}: no 'components' mapping; is this a snakesim config.yaml?")
    columns, data = read_signals(need[1])
    summary_path = run_dir / "summary.json"
    summary = json.loads(summary_path.read_text()) if summary_path.is_file() else {}
    return cfg, columns, data, summary


def replay(run_dir, target: VizTarget | None = None, body_frames: bool = False, registry=None) -> ReplayReport:
    from snakesim.components.terrain import Terrain
    from snakesim.framework.registry import default_registry

    from .blueprint import default_blueprint
    from .scene_log import SceneLog
    from .terrain_geometry import terrain_mesh

    run_dir = Path(run_dir)
    cfg, columns, data, summary = load_run(run_dir)
    registry = registry or default_registry()
    target = target or VizTarget("save", str(run_dir / "replay.rrd"))
    t = data[:, 0]
    notes: list[str] = []
    if summary.get("outcome") == INCOMPLETE:        # written while the run was under way: killed, or running
        notes.append(f"{run_dir} is incomplete: the run had not finished (started {summary.get('started')}, pid "
                     f"{summary.get('pid')}); replaying the {len(t)} rows it flushed, to t = "
                     f"{t[-1] if len(t) else 0.0:g} s")

    classes = {}
    for name, spec in cfg["components"].items():
        try:
            classes[name] = registry.component(spec["type"])
        except Exception:
            notes.append(f"component '{name}': type '{spec.get('type')}' is not registered here; skipped")
    viz = next((spec.get("params", {}) for n, spec in cfg["components"].items()
                if spec.get("type") == "rerun_viewer"), {})
    vp = RerunSinkParams(**{k: v for k, v in viz.items() if k in ("terrain_extent", "terrain_cell", "terrain_center",
                                                                 "terrain_cutaway", "frame_length", "force_scale")})
    records = [r for r in cfg.get("record", []) if isinstance(r, str)]

    # robot ---------------------------------------------------------------------------
    robot = next((n for n, c in classes.items() if provides_robot(c)), None)
    links, meshes, visuals, poses, pose_t = (), [], None, None, t
    if robot is not None:
        comp = build_robot(robot, classes[robot], cfg["components"][robot].get("params", {}))
        links = comp.robot.links
        meshes, visuals = comp.robot.derived(link_meshes), comp.robot.derived(robot_visuals)
        poses, pose_t, note = _robot_poses(comp, columns, data, records)
        if note:
            notes.append(note)

    # terrain -------------------------------------------------------------------------
    tmesh = None
    for name, cls in classes.items():
        port = next((p for p, o in cls.outputs.items() if isinstance(o.signal, Structured)
                     and isinstance(o.signal.cls, type) and issubclass(o.signal.cls, Terrain)), None)
        if port is not None:
            terrain = Harness(cls(name, cfg["components"][name].get("params", {}))).outputs()[port]
            center = (np.asarray(vp.terrain_center) if vp.terrain_center is not None
                      else poses[0, :, :3].mean(axis=0) if poses is not None and poses.shape[1] else np.zeros(3))
            tmesh = terrain_mesh(terrain, center, vp.terrain_extent, vp.terrain_cell, vp.terrain_cutaway)
            break

    # series --------------------------------------------------------------------------
    series = []
    for ref in records:
        idx, names = signal_columns(columns, ref)
        if idx:
            series.append((ref, names, idx))

    # tethers: straight ropes from a tethers component's params and the poses
    ropes = None
    if poses is not None:
        from .sink import _ropes

        lines = next((ln for ln in (tether_lines(cls, cfg["components"][n].get("params", {}))
                                    for n, cls in classes.items()) if ln), [])
        ropes = _ropes(lines, links) if lines else None

    first = poses[0, :, :3] if poses is not None and poses.shape[1] else np.zeros((1, 3))
    bp = default_blueprint(first, [E.series_path(s) for s, _, _ in series])
    rec, used = open_recording(target, "snakesim", blueprint=bp)
    log = SceneLog(rec, robot=robot, link_names=links, meshes=meshes, visuals=visuals,
                   series=[(s, names, len(idx)) for s, names, idx in series],
                   body_frames=body_frames, frame_length=vp.frame_length, force_scale=vp.force_scale,
                   tethers=ropes is not None)
    log.log_static(tmesh)
    if poses is not None:
        log.send_poses(pose_t, poses)
    if ropes is not None:
        log.send_tethers(pose_t, [list(ropes.segments(p)) for p in poses])
    for s, _, idx in series:
        log.send_series(s, t, data[:, idx])
    rtf = summary.get("real_time_factor")
    if isinstance(rtf, (int, float)) and np.isfinite(rtf):
        # the run's average: a replay has no per-frame wall clock
        log.send_series(E.REAL_TIME_FACTOR, np.array([t[0], t[-1]]), np.array([rtf, rtf]), path=E.REAL_TIME_FACTOR)
    rec.flush()
    if used.mode == "save":
        rec.disconnect()
    return ReplayReport(used, len(t), [s for s, _, _ in series], notes)


def build_robot(name: str, cls, params: dict):
    """The robot-providing component of a finished run, built from its recorded params (its
    ``robot`` is the RobotModel the run used)."""
    try:
        return cls(name, params)
    except Exception as e:
        raise SnakesimError(f"replay: cannot rebuild the robot component '{name}' ({cls.type_name}) from "
                            f"config.yaml: {e}") from None


def _robot_poses(comp, columns, data, records):
    """(poses (n, nl, 7), times (n,), note) from the recording, or computed through ``comp`` (the
    built robot-providing component, see :func:`build_robot`)."""
    t = data[:, 0]
    robot, links = comp.name, comp.robot.links
    ref = f"{robot}.link_poses"
    if ref in records:
        idx, _ = signal_columns(columns, ref)
        if len(idx) == 7 * len(links):
            return data[:, idx].reshape(len(t), len(links), 7), t, None
    h = Harness(comp)
    calc = getattr(comp, comp.outputs["link_poses"].calc or "output")
    nq = h.y.q.size if hasattr(h.y, "q") else None
    qref = f"{robot}.q"
    if qref in records and nq:
        idx, _ = signal_columns(columns, qref)
        if len(idx) == nq:
            out = np.empty((len(t), len(links), 7))
            x = h.x                           # in place: the component's cache holds views of it
            x[nq:] = 0.0
            for k in range(len(t)):           # replay only: one forward kinematics per recorded row
                x[:nq] = data[k, idx]
                calc(t[k], x, h.u, h.y)
                out[k] = h.y.link_poses
            return out, t, None
    calc(t[0], h.x, h.u, h.y)
    return (h.y.link_poses.copy()[None], t[:1],
            f"{ref} and {qref} were not recorded, so the robot is shown at its initial pose; "
            f"add '{ref}' (or '{qref}') to the scene's record list to replay its motion")
