"""A still picture of one instant of a snakesim .rrd recording, drawn with matplotlib.

    python -m snakesim.components.viz.snapshot RUN.rrd OUT.png [--time 1.0] [--elev 25] [--azim -60]

For documentation on machines where rerun's own viewer cannot render (it
needs a GPU or a working software Vulkan/WebGPU). Reads the recording back
with rerun's reader and draws what the viewer would show at ``--time``: the
static meshes (terrain, robot link visuals; a changing terrain's latest mesh)
placed by each link's latest Transform3D, tether strips and contact
points/arrows. Flat Lambert shading
of the logged vertex colours; no textures, no anti-aliasing.
"""

from __future__ import annotations

import argparse

import numpy as np

from snakesim.components.multibody.pose_quaternions import rotation_matrices

from . import entities as E


def scene_at(path, time: float):
    """{'meshes': [(world vertices, faces, rgba uint8)], 'strips': [...], 'points': (n, 3),
    'arrows': [(origins, vectors, rgba)]} at simulated ``time`` (s)."""
    import rerun.chunk as rc

    static, latest = {}, {}
    for c in rc.RrdReader(path).stream().to_chunks():
        b = c.to_record_batch()
        names = b.schema.names
        if c.is_static:
            static.setdefault(c.entity_path, {}).update({n: b.column(n).to_pylist()[0] for n in names})
            continue
        if "sim" not in names:
            continue
        ts = [d.total_seconds() for d in b.column("sim").to_pylist()]
        for n in names:
            if n in ("sim", "rerun.controls.RowId"):
                continue
            vals = b.column(n).to_pylist()
            for t, v in zip(ts, vals):
                key = (c.entity_path, n)
                if t <= time + 1e-9 and (key not in latest or latest[key][0] <= t):
                    latest[key] = (t, v)

    def now(entity, name):
        return latest.get((entity, name), (None, None))[1]

    # a terrain whose state changes is logged in time (scene_log.log_terrain): its mesh at ``time``
    for (entity, name), (_, value) in latest.items():
        if name.startswith("Mesh3D:"):
            static.setdefault(entity, {})[name] = value
    meshes = []
    for entity, comps in static.items():
        if "Mesh3D:vertex_positions" not in comps:
            continue
        v = np.asarray(comps["Mesh3D:vertex_positions"], dtype=float)
        f = np.asarray(comps["Mesh3D:triangle_indices"], dtype=np.int64)
        col = comps.get("Mesh3D:vertex_colors")
        rgba = (np.array([[(c >> 24) & 255, (c >> 16) & 255, (c >> 8) & 255, c & 255] for c in col], dtype=np.uint8)
                if col else np.full((len(v), 4), 200, dtype=np.uint8))
        parent = entity.rsplit("/", 1)[0] if entity.endswith("/visual") else None
        if parent is not None:
            tr, q = now(parent, "Transform3D:translation"), now(parent, "Transform3D:quaternion")
            if tr is None:
                continue
            v = v @ rotation_matrices(q[0]).T + np.asarray(tr[0])        # one instance per row
        meshes.append((entity, v, f, rgba))
    strips = now("/" + E.TETHERS, "LineStrips3D:strips") or []
    points = np.asarray(now("/" + E.CONTACT_POINTS, "Points3D:positions") or np.zeros((0, 3)), dtype=float)
    arrows = []
    for entity, color in (("/" + E.CONTACT_NORMAL, (70, 140, 255)), ("/" + E.CONTACT_FRICTION, (255, 150, 40))):
        o, vec = now(entity, "Arrows3D:origins"), now(entity, "Arrows3D:vectors")
        if o and vec:
            arrows.append((np.asarray(o, float), np.asarray(vec, float), color))
    return {"meshes": meshes, "strips": strips, "points": points, "arrows": arrows}


def render(path, out, time: float = 0.0, elev: float = 25.0, azim: float = -60.0, size=(10, 6.5),
           focus: str = "robot", margin: float = 0.6, title: str | None = None) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    s = scene_at(path, time)
    light = np.array([0.3, -0.5, 0.8])
    light /= np.linalg.norm(light)
    fig = plt.figure(figsize=size, dpi=110)
    ax = fig.add_subplot(projection="3d")
    robot_pts = [v for e, v, _, _ in s["meshes"] if "/terrain" not in e]
    ctr_pts = np.vstack(robot_pts) if robot_pts and focus == "robot" else np.vstack([v for _, v, _, _ in s["meshes"]])
    lo, hi = ctr_pts.min(axis=0) - margin, ctr_pts.max(axis=0) + margin
    tris, colors = [], []
    for entity, v, f, rgba in s["meshes"]:
        tri = v[f]
        if "/terrain" in entity:                     # only the part of the terrain around the robot
            c = tri.mean(axis=1)
            keep = np.all((c >= lo) & (c <= hi), axis=1)
            tri, f = tri[keep], f[keep]
        if not len(tri):
            continue
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
        shade = 0.35 + 0.65 * np.abs(n @ light)
        tris.append(tri)
        colors.append(np.clip(rgba[f].mean(axis=1)[:, :3] / 255.0 * shade[:, None], 0, 1))
    # one collection: matplotlib depth-sorts polygons within a collection, not across them
    ax.add_collection3d(Poly3DCollection(np.concatenate(tris), facecolors=np.concatenate(colors),
                                         linewidths=0, edgecolors="none"))
    if s["strips"]:
        ax.add_collection3d(Line3DCollection([np.asarray(x) for x in s["strips"]], colors=[(0.98, 0.78, 0.16)],
                                             linewidths=2.5))
    if len(s["points"]):
        p = s["points"]
        ax.scatter(p[:, 0], p[:, 1], p[:, 2], s=6, c=[(1.0, 0.9, 0.24)], depthshade=False)
    for o, vec, color in s["arrows"]:
        segs = np.stack([o, o + vec], axis=1)
        ax.add_collection3d(Line3DCollection(segs, colors=[np.array(color) / 255], linewidths=1.5))
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(hi - lo)                        # metres the same length on every axis
    ax.view_init(elev=elev, azim=azim)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    if title:
        ax.set_title(title)
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("rrd")
    ap.add_argument("out")
    ap.add_argument("--time", type=float, default=0.0, help="simulated time, s")
    ap.add_argument("--elev", type=float, default=25.0)
    ap.add_argument("--azim", type=float, default=-60.0)
    ap.add_argument("--title")
    a = ap.parse_args(argv)
    render(a.rrd, a.out, a.time, a.elev, a.azim, title=a.title)


if __name__ == "__main__":
    main()
