"""``snakesim mcap recover FILE [-o OUT]``: a readable MCAP rewritten from one cut short.

A run killed while it records (``--ros2-mcap``, :mod:`.mcap_recorder`) leaves a file without its summary
and footer, perhaps ending in a partial record: the standard readers (``mcap.reader.make_reader``,
Foxglove, ``ros2 bag``) refuse it. :func:`recover` reads it record by record up to the last whole one
(a chunk whose data do not decompress or fail their CRC is skipped, and counted), and writes every schema,
channel, message, attachment and metadata record it got into a new, complete file: chunked and zstd
compressed, with its message indexes, summary and footer, so any MCAP reader opens it and seeks in it,
as ``ros2 bag reindex`` or the Go ``mcap recover`` would. Messages keep their channel, log and publish
times, sequence numbers and bytes, in the order they were written. A complete file is rewritten as it is.

Nothing here imports the simulator: only the ``mcap`` package.
"""

from __future__ import annotations

import dataclasses
import io
import os
from pathlib import Path

MAGIC = b"\x89MCAP0\r\n"
_RECORD_HEAD = 9                  # opcode (1 byte), length (uint64 little-endian)


class RecoverError(Exception):
    """The input cannot be recovered (missing, empty, not an MCAP file, nothing readable): the message names it."""


@dataclasses.dataclass
class Recovered:
    """What :func:`recover` read and wrote."""

    source: Path
    out: Path
    counts: dict[str, int]            # messages recovered per channel topic, in the order channels appeared
    size: int                         # bytes of the input
    read_to: int                      # bytes of the input read as whole records
    complete: bool                    # the input had its footer (nothing was missing)
    stopped: str | None = None        # why reading stopped before the footer
    bad_chunks: int = 0               # chunks skipped (data that do not decompress or fail their CRC)
    orphans: int = 0                  # messages on a channel the file never defined (skipped)

    @property
    def messages(self) -> int:
        return sum(self.counts.values())

    def summary(self) -> str:
        """The report ``snakesim mcap recover`` prints: what was read, what was written, per channel."""
        if self.complete:
            how = "the file was complete (summary and footer present)"
        else:
            how = (f"read {self.read_to} of {self.size} bytes as whole records"
                   + (f"; {self.stopped}" if self.stopped else ""))
        lines = [f"{self.source} -> {self.out}: {self.messages} messages on {len(self.counts)} channels ({how})"]
        if self.bad_chunks:
            lines.append(f"  {self.bad_chunks} damaged chunk(s) skipped")
        if self.orphans:
            lines.append(f"  {self.orphans} message(s) on undefined channels skipped")
        width = max((len(t) for t in self.counts), default=0)
        lines += [f"  {topic:<{width}}  {n}" for topic, n in self.counts.items()]
        return "\n".join(lines)


def default_output(path: Path) -> Path:
    """``run.mcap`` -> ``run.recovered.mcap`` beside it."""
    return path.with_name(f"{path.stem}.recovered{path.suffix or '.mcap'}")


def recover(source, out=None, chunk_size: int = 1 << 20) -> Recovered:
    """Rewrite the MCAP file ``source`` (perhaps cut short) as a complete file ``out`` (default
    ``<stem>.recovered.mcap``). Raises :class:`RecoverError` naming ``source`` when it is missing, empty,
    not an MCAP file, or ``out`` is ``source``."""
    from mcap.writer import CompressionType, Writer

    source = Path(source)
    out = Path(out) if out is not None else default_output(source)
    if not source.exists():
        raise RecoverError(f"{source}: no such file")
    if not source.is_file():
        raise RecoverError(f"{source}: not a file")
    size = source.stat().st_size
    if size == 0:
        raise RecoverError(f"{source}: empty file (0 bytes), not an MCAP file")
    if out.resolve() == source.resolve():
        raise RecoverError(f"{source}: the output would replace the input; name another file with -o")
    with open(source, "rb") as f:
        if f.read(len(MAGIC)) != MAGIC:
            raise RecoverError(f"{source}: not an MCAP file (it does not start with the MCAP magic bytes)")
        records = _Records(f, size)
        header = records.header(source)
        out.parent.mkdir(parents=True, exist_ok=True)
        tmp = out.with_name(out.name + ".part")
        try:
            with open(tmp, "wb") as g:
                writer = Writer(g, chunk_size=chunk_size, compression=CompressionType.ZSTD)
                writer.start(profile=header.profile, library=header.library)
                result = _copy(records, writer, source, out, size)
                writer.finish()
            os.replace(tmp, out)
        finally:
            if tmp.exists():
                tmp.unlink()
    return result


class _Records:
    """The input's records after the magic, one at a time, up to the first that is not whole."""

    def __init__(self, f, size: int):
        self.f, self.size = f, size
        self.pos = len(MAGIC)           # end of the last whole record
        self.stopped: str | None = None

    def next(self):
        """(opcode, content bytes) of the next whole record, or None (``stopped`` says why, unless at the end)."""
        head = self.f.read(_RECORD_HEAD)
        if len(head) < _RECORD_HEAD:
            self.stopped = (f"cut short at byte {self.pos} (a partial record: {len(head)} bytes)" if head else
                            f"ends at byte {self.pos} without its summary and footer")
            return None
        opcode, length = head[0], int.from_bytes(head[1:], "little")
        if length > self.size - self.pos - _RECORD_HEAD:
            self.stopped = (f"cut short in a {_name(opcode)} record at byte {self.pos} "
                            f"({self.size - self.pos - _RECORD_HEAD} of its {length} bytes)")
            return None
        content = self.f.read(length)
        if len(content) < length:
            self.stopped = f"a record at byte {self.pos} is cut short"
            return None
        self.pos += _RECORD_HEAD + length
        return opcode, content

    def header(self, source: Path):
        from mcap.data_stream import ReadDataStream
        from mcap.opcode import Opcode
        from mcap.records import Header

        rec = self.next()
        if rec is None:
            raise RecoverError(f"{source}: an MCAP file cut short in its header ({self.size} bytes): "
                               f"nothing to recover")
        if rec[0] != Opcode.HEADER:
            raise RecoverError(f"{source}: not an MCAP file (no Header record after the magic bytes)")
        return Header.read(ReadDataStream(io.BytesIO(rec[1])))


def _copy(records: _Records, writer, source: Path, out: Path, size: int) -> Recovered:
    """Every schema, channel, message, attachment and metadata record up to the data end, into ``writer``."""
    from mcap.data_stream import ReadDataStream
    from mcap.opcode import Opcode
    from mcap.records import Attachment, Channel, Chunk, Message, Metadata, Schema
    from mcap.stream_reader import breakup_chunk

    schemas: dict[int, int] = {}        # input id -> output id
    channels: dict[int, tuple[int, str]] = {}
    counts: dict[str, int] = {}
    result = Recovered(source=source, out=out, counts=counts, size=size, read_to=0, complete=False)

    def take(record) -> None:
        if isinstance(record, Schema):
            if record.id not in schemas:
                schemas[record.id] = writer.register_schema(name=record.name, encoding=record.encoding,
                                                            data=record.data)
        elif isinstance(record, Channel):
            if record.id not in channels:
                sid = schemas.get(record.schema_id, 0)
                channels[record.id] = (writer.register_channel(topic=record.topic,
                                                               message_encoding=record.message_encoding,
                                                               schema_id=sid, metadata=dict(record.metadata)),
                                       record.topic)
                counts.setdefault(record.topic, 0)
        elif isinstance(record, Message):
            ch = channels.get(record.channel_id)
            if ch is None:
                result.orphans += 1
                return
            writer.add_message(ch[0], log_time=record.log_time, data=record.data,
                               publish_time=record.publish_time, sequence=record.sequence)
            counts[ch[1]] += 1

    while True:
        rec = records.next()
        if rec is None:
            result.stopped = records.stopped
            break
        opcode, content = rec
        stream = ReadDataStream(io.BytesIO(content))
        if opcode == Opcode.CHUNK:
            try:
                inner = breakup_chunk(Chunk.read(stream), validate_crc=True)
            except Exception:               # damaged data (a torn write): the records around it still stand
                result.bad_chunks += 1
                continue
            for r in inner:
                take(r)
        elif opcode == Opcode.SCHEMA:
            take(Schema.read(stream))
        elif opcode == Opcode.CHANNEL:
            take(Channel.read(stream))
        elif opcode == Opcode.MESSAGE:
            take(Message.read(stream, len(content)))
        elif opcode == Opcode.ATTACHMENT:
            a = Attachment.read(stream)
            writer.add_attachment(create_time=a.create_time, log_time=a.log_time, name=a.name,
                                  media_type=a.media_type, data=a.data)
        elif opcode == Opcode.METADATA:
            m = Metadata.read(stream)
            writer.add_metadata(m.name, dict(m.metadata))
        elif opcode in (Opcode.DATA_END, Opcode.FOOTER):
            # the summary section follows (or the footer itself): the rewritten file gets its own
            result.complete = _has_footer(records.f, size)
            result.stopped = None if result.complete else "cut short in its summary section, after all its data"
            break
        # message indexes, chunk indexes, statistics ...: rebuilt by the writer
    result.read_to = records.pos
    return result


def _name(opcode: int) -> str:
    from mcap.opcode import Opcode

    try:
        return Opcode(opcode).name.lower().replace("_", " ")
    except ValueError:
        return f"0x{opcode:02x}"


def _has_footer(f, size: int) -> bool:
    """Whether the file ends in a footer and the closing magic bytes."""
    from mcap.opcode import Opcode

    tail = 8 + _RECORD_HEAD + 20
    if size < len(MAGIC) + tail:
        return False
    here = f.tell()
    try:
        f.seek(size - tail)
        end = f.read(tail)
    finally:
        f.seek(here)
    return end[-8:] == MAGIC and end[0] == Opcode.FOOTER
