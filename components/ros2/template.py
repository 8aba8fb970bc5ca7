"""Messages serialised once, then patched in place: a publish that allocates (almost) nothing.

cyclonedds' Python serialiser builds a new ``bytes`` per sample (~30 µs for a
40-link TFMessage). The messages snakesim publishes keep their shape for a
whole run (the same joint names, the same frames): only floats and stamps
change. So a :class:`CdrTemplate` serialises the message once with cyclonedds
(the layout is then cyclonedds' own, byte for byte), with sentinel values in
the fields that change, finds them in the bytes and keeps numpy views of those
places. Each publish writes the new values through index arrays into the
buffer and hands the buffer to Cyclone's C writer.

XCDR1 aligns 8-byte values to 8 and 4-byte values to 4, counted from the end
of the 4-byte encapsulation header, so every float64 of the message is an
element of one float64 view of ``buf[4:]`` and every stamp word one of a
uint32 view: a field is a list of element indices.
"""

from __future__ import annotations

import numpy as np

_SEC0 = 0x5EC00000            # sentinel seconds: _SEC0 + k for the k-th stamp
_NSEC = 0x3ADBEEF0            # sentinel nanoseconds (< 1e9)


class CdrTemplateError(RuntimeError):
    pass


class CdrTemplate:
    """``msg`` (an IdlStruct) serialised once; ``floats[name]`` and ``stamps`` are patched per write.

    Build with :meth:`of`: ``float_fields`` maps a name to ``(setter, n)`` where
    ``setter(msg, values)`` puts n float64 values into the message (the
    sentinels); ``stamp_setters`` put a Time into each stamp the message has.
    """

    def __init__(self, buf: bytearray, float_index: dict[str, np.ndarray], sec_index: np.ndarray):
        self.buf = buf
        self._f = np.frombuffer(memoryview(buf)[4:4 + (len(buf) - 4) // 8 * 8], dtype="<f8")
        self._u = np.frombuffer(memoryview(buf)[4:4 + (len(buf) - 4) // 4 * 4], dtype="<u4")
        self.float_index = float_index
        self.sec_index = sec_index
        self.nsec_index = sec_index + 1
        #: name -> indices into the values given to set_floats (e.g. the rows a message keeps); default all
        self.selection: dict[str, np.ndarray] = {}

    @classmethod
    def of(cls, msg, float_fields: dict, stamp_setters=()) -> "CdrTemplate":
        from .messages import Time

        rng = np.random.default_rng(20240611)
        sentinels = {}
        for name, (setter, n) in float_fields.items():
            v = 1e6 + rng.random(n) * 1e5                 # distinct, never a real value's bytes by chance
            sentinels[name] = v
            setter(msg, v)
        for k, set_stamp in enumerate(stamp_setters):
            set_stamp(msg, Time(sec=_SEC0 + k, nanosec=_NSEC))
        raw = msg.serialize()
        if raw[:2] != b"\x00\x01":
            raise CdrTemplateError(f"expected little-endian XCDR1 (encapsulation 00 01), got {raw[:4].hex()}")
        buf = bytearray(raw.ljust((len(raw) + 3) & ~3, b"\0"))      # as DataWriter.write pads it
        body = bytes(buf[4:])
        f = np.frombuffer(body[:len(body) // 8 * 8], dtype="<f8")
        u = np.frombuffer(body[:len(body) // 4 * 4], dtype="<u4")
        index = {}
        for name, v in sentinels.items():
            idx = np.array([_only(np.flatnonzero(f == x), name) for x in v], dtype=np.intp)
            index[name] = idx
        secs = np.array([_only(np.flatnonzero(u == _SEC0 + k), "stamp") for k in range(len(stamp_setters))],
                        dtype=np.intp)
        if len(secs) and not np.all(u[secs + 1] == _NSEC):
            raise CdrTemplateError("stamp nanoseconds not after seconds")
        return cls(buf, index, secs)

    def set_floats(self, name: str, values) -> None:
        """Write ``values`` (flattened, float64; ``values[selection[name]]`` when set) into field ``name``."""
        sel = self.selection.get(name)
        self._f[self.float_index[name]] = values if sel is None else values[sel]

    def set_stamp(self, sec: int, nanosec: int) -> None:
        u = self._u
        u[self.sec_index] = sec
        u[self.nsec_index] = nanosec


def _only(hits, what):
    if len(hits) != 1:
        raise CdrTemplateError(f"template field '{what}': sentinel found {len(hits)} times")
    return hits[0]


class RawWriter:
    """Writes a template's buffer through Cyclone's C writer, with the sample's source timestamp unset.

    Falls back to ``writer.write(sample)`` semantics only in the sense of the same bytes: the
    buffer is what ``DataWriter.write`` would have produced for the patched sample."""

    def __init__(self, writer):
        from cyclonedds._clayer import ddspy_write

        self._write = ddspy_write
        self._ref = writer._ref
        self.writer = writer

    def write(self, buf) -> None:
        ret = self._write(self._ref, buf)
        if ret < 0:
            from cyclonedds.core import DDSException

            raise DDSException(ret, f"writing on {self.writer.topic.name}")
