"""nav_msgs/OccupancyGrid and grid_map_msgs/GridMap: the terrain map (components/sensors/terrain_map.py) as ROS 2
messages.

Types. OccupancyGrid is generated like every other message snakesim sends (:func:`.messages.ros_type`, from
rosbags' standard definition). grid_map_msgs is not among rosbags' standard messages: its two ROS 2 .msg files
(ANYbotics/grid_map, ``ros2`` branch; comments dropped) are :data:`GRID_MAP_TEXT`, parsed with rosbags' own
.msg parser and registered in the same typestore (:func:`register_grid_map`), so the IdlStruct
(``grid_map_msgs::msg::dds_::GridMap_``) and the MCAP schema text come from one definition.

Layouts (what a reader needs to put a cell back in the world)::

    OccupancyGrid  header.frame_id = world frame, header.stamp = info.map_load_time = the sample's time
                   info.resolution, width = height = cells, info.origin = pose of the corner of cell (0, 0)
                   (identity orientation); data[r · width + c]: row r along +y, column c along +x (as the
                   terrain map's ``cost`` port holds it): int8, 0 free .. 100 lethal, −1 unknown
    GridMap        header as above; info.resolution, length_x = length_y = cells · resolution, info.pose =
                   the map's centre; layers ["elevation", "slope"] (m, rad; NaN unknown, as grid_map marks
                   invalid cells), basic_layers ["elevation"]; each data[k] a Float32MultiArray in grid_map's
                   own storage (grid_map_ros' toMessage): dim[0] "column_index", dim[1] "row_index", column
                   major, index (i, j) at centre − (i, j)·resolution + (length/2 − resolution/2): i runs
                   along −x, j along −y. For the terrain map's grid h[r, c] that is ``h[::-1, ::-1]``
                   flattened row-major (:func:`grid_map_layer`); outer and inner start index 0.

A publish patches a message serialised once (:class:`.template.CdrTemplate` for the stamps and the origin;
the int8 / float32 arrays through byte views found the same way, by a pattern written at build), so a
publish costs a copy of the grid, never a per-element serialisation.

tests/ros2/test_terrain_map_topics.py decodes the bytes with rosbags' codec and, from an MCAP file,
with mcap-ros2-support's decoder from the file's own schema.
"""

from __future__ import annotations

import numpy as np

OCCUPANCY_GRID = "nav_msgs/msg/OccupancyGrid"
GRID_MAP = "grid_map_msgs/msg/GridMap"
GRID_MAP_INFO = "grid_map_msgs/msg/GridMapInfo"
#: the GridMap's layers, in order, and the port of the terrain map each comes from
LAYERS = ("elevation", "slope")

#: grid_map_msgs' ROS 2 message definitions (ANYbotics/grid_map, ros2 branch), dependencies first
GRID_MAP_TEXT = {
    GRID_MAP_INFO: "float64 resolution\nfloat64 length_x\nfloat64 length_y\ngeometry_msgs/Pose pose\n",
    GRID_MAP: ("std_msgs/Header header\nGridMapInfo info\nstring[] layers\nstring[] basic_layers\n"
               "std_msgs/Float32MultiArray[] data\nuint16 outer_start_index\nuint16 inner_start_index\n"),
}


def register_grid_map(store=None) -> None:
    """Register :data:`GRID_MAP_TEXT` in ``store`` (default: the typestores :func:`.messages.ros_type` and
    the MCAP schemas read: ``typestore()`` and ``typestore(STORE)`` are two cache entries); idempotent."""
    from rosbags.typesys import get_types_from_msg

    from .messages import STORE, typestore

    for s in ([store] if store is not None else [typestore(), typestore(STORE)]):
        if GRID_MAP in s.fielddefs:
            continue
        types = {}
        for name, text in GRID_MAP_TEXT.items():
            types.update(get_types_from_msg(text, name))
        s.register(types)


def occupancy_grid_type():
    from .messages import ros_type

    return ros_type(OCCUPANCY_GRID)


def grid_map_type():
    from .messages import ros_type

    register_grid_map()
    return ros_type(GRID_MAP)


def grid_map_layer(grid: np.ndarray) -> np.ndarray:
    """A terrain-map grid (rows +y, columns +x) as grid_map's column-major storage, flattened (module docstring)."""
    return np.ascontiguousarray(np.asarray(grid)[::-1, ::-1]).reshape(-1)


def _find(buf: bytearray, pattern: bytes, what: str) -> int:
    at = buf.find(pattern)
    if at < 0 or buf.find(pattern, at + 1) >= 0:
        from .template import CdrTemplateError

        raise CdrTemplateError(f"template field '{what}': pattern found {'no' if at < 0 else 'more than one'} time")
    return at


def _set_position(point, v) -> None:
    point.x, point.y, point.z = (float(a) for a in v[:3])


class OccupancyGridTemplate:
    """A nav_msgs/OccupancyGrid of ``cells`` × ``cells`` serialised once; :meth:`encode` patches the stamps,
    the origin and the data in place and returns the buffer (CDR with its encapsulation header, padded to 4
    bytes as DataWriter.write pads)."""

    def __init__(self, frame_id: str, cells: int, resolution: float):
        from . import messages as M
        from .template import CdrTemplate

        Grid, Meta = occupancy_grid_type(), M.ros_type("nav_msgs/msg/MapMetaData")
        n = cells * cells
        pattern = np.random.default_rng(7).integers(-128, 128, n, dtype=np.int8)
        msg = Grid(header=M.Header(frame_id=frame_id),
                   info=Meta(resolution=float(resolution), width=cells, height=cells, origin=M.Pose()),
                   data=pattern.tolist())
        self.tpl = CdrTemplate.of(msg, {"origin": (lambda m, v: _set_position(m.info.origin.position, v), 3)},
                                  [lambda m, tm: setattr(m.header, "stamp", tm),
                                   lambda m, tm: setattr(m.info, "map_load_time", tm)])
        buf = self.tpl.buf
        at = _find(buf, pattern.tobytes(), "data")
        self.data = np.frombuffer(memoryview(buf)[at:at + n], dtype=np.int8)
        self.shape = (cells, cells)

    def encode(self, t: float, origin, cost) -> bytearray:
        tpl = self.tpl
        tpl.set_stamp(*divmod(int(round(max(t, 0.0) * 1e9)), 1_000_000_000))
        tpl.set_floats("origin", np.asarray(origin, dtype=float).reshape(3))
        self.data[:] = np.asarray(cost, dtype=np.int8).reshape(-1)
        return tpl.buf


class GridMapTemplate:
    """A grid_map_msgs/GridMap with the :data:`LAYERS` of a ``cells`` × ``cells`` map serialised once;
    :meth:`encode` patches the stamp, the centre and the layers in place and returns the buffer."""

    def __init__(self, frame_id: str, cells: int, resolution: float):
        from . import messages as M
        from .template import CdrTemplate

        GridMap = grid_map_type()
        Info, Array = M.ros_type(GRID_MAP_INFO), M.ros_type("std_msgs/msg/Float32MultiArray")
        Dim, Layout = M.MultiArrayDimension, M.MultiArrayLayout
        n = cells * cells
        rng = np.random.default_rng(11)
        # distinct float32 patterns, one per layer (finite, never a real value's bytes by chance)
        patterns = [(1e6 + rng.random(n) * 1e5).astype(np.float32) for _ in LAYERS]
        layout = Layout(dim=[Dim(label="column_index", size=cells, stride=n),
                             Dim(label="row_index", size=cells, stride=cells)], data_offset=0)
        length = cells * float(resolution)
        msg = GridMap(header=M.Header(frame_id=frame_id),
                      info=Info(resolution=float(resolution), length_x=length, length_y=length, pose=M.Pose()),
                      layers=list(LAYERS), basic_layers=[LAYERS[0]],
                      data=[Array(layout=layout, data=p.tolist()) for p in patterns])
        self.tpl = CdrTemplate.of(msg, {"center": (lambda m, v: _set_position(m.info.pose.position, v), 3)},
                                  [lambda m, tm: setattr(m.header, "stamp", tm)])
        buf = self.tpl.buf
        self.layers = []
        for name, p in zip(LAYERS, patterns):
            at = _find(buf, p.tobytes(), name)
            self.layers.append(np.frombuffer(memoryview(buf)[at:at + 4 * n], dtype="<f4"))
        self.half = 0.5 * length

    def encode(self, t: float, origin, *layers) -> bytearray:
        """``origin``: the corner of cell (0, 0) (the terrain map's map_origin); ``layers``: the grids of
        :data:`LAYERS`, rows +y, columns +x."""
        tpl = self.tpl
        tpl.set_stamp(*divmod(int(round(max(t, 0.0) * 1e9)), 1_000_000_000))
        o = np.asarray(origin, dtype=float).reshape(3)
        tpl.set_floats("center", np.array([o[0] + self.half, o[1] + self.half, 0.0]))
        for view, grid in zip(self.layers, layers):
            view[:] = grid_map_layer(grid)
        return tpl.buf
