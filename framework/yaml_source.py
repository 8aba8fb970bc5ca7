"""YAML loading that remembers where every mapping key came from.

Mappings load as :class:`LocatedDict` (a plain dict plus ``file`` and the line
of each key), so a schema error deep inside an assembly can still be reported
as ``scene.yaml:14: components.pend.params.length``. Only safe YAML tags.

Bounded: a file is UTF-8 text (a binary or otherwise encoded file is refused naming the byte
offset), nests at most :data:`MAX_DEPTH` collections deep, and expands (aliases counted at every
use) to at most :data:`MAX_NODES` nodes, so an alias bomb is refused before it is built.
"""

from __future__ import annotations

import re
from pathlib import Path

import yaml

from .errors import ConfigError


class LocatedDict(dict):
    """dict + source positions: ``pos[key] = (file, line)`` (1-based lines).

    After layering, keys of one mapping may come from different files.
    """

    file: str | None = None
    line: int | None = None

    def __init__(self, *a, **kw):
        super().__init__(*a, **kw)
        self.pos: dict = {}

    def where(self, key=None) -> str | None:
        file, line = self.pos.get(key, (self.file, self.line)) if key is not None else (self.file, self.line)
        if file is None:
            return None
        return f"{file}:{line}" if line else file


class LocatedList(list):
    file: str | None = None
    line: int | None = None

    def __init__(self, *a):
        super().__init__(*a)
        self.lines: list = []

    def where(self, index=None) -> str | None:
        line = self.line
        if index is not None and 0 <= index < len(self.lines):
            line = self.lines[index]
        if self.file is None:
            return None
        return f"{self.file}:{line}" if line else self.file


#: deepest nesting of mappings and lists in one YAML document
MAX_DEPTH = 64
#: most nodes a document may expand to, each alias counted at every place it is used
MAX_NODES = 1_000_000


class _Loader(yaml.SafeLoader):
    _depth = 0

    def compose_node(self, parent, index):
        # the composer recurses once per level: refuse before Python's recursion limit does
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                mark = self.peek_event().start_mark
                raise ConfigError(f"YAML nests more than {MAX_DEPTH} levels deep (the limit)",
                                  f"{self.source_name}:{mark.line + 1}")
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


def _expanded_size(node, source: str) -> int:
    """Nodes the document becomes once every alias is expanded (memoised per node: linear time);
    a recursive alias (a node inside itself) is refused."""
    sizes: dict[int, int] = {}
    active: set[int] = set()

    def size(n) -> int:
        key = id(n)
        if key in sizes:
            return sizes[key]
        if key in active:
            raise ConfigError("recursive YAML alias (a node that contains itself)", f"{source}:{n.start_mark.line + 1}")
        active.add(key)
        total = 1
        if isinstance(n, yaml.MappingNode):
            total += sum(size(k) + size(v) for k, v in n.value)
        elif isinstance(n, yaml.SequenceNode):
            total += sum(size(v) for v in n.value)
        active.discard(key)
        if total > MAX_NODES:
            raise ConfigError(f"YAML expands to more than {MAX_NODES:,} nodes (the limit; aliases count at "
                              "every use: an alias bomb?)", f"{source}:{n.start_mark.line + 1}")
        sizes[key] = total
        return total

    return size(node)


def _construct_mapping(loader: _Loader, node: yaml.MappingNode):
    # merge keys (<<: *anchor) put the merged pairs first; later (own) keys override
    # them, as YAML merge semantics say: only a key written twice is a duplicate
    own_nodes = {id(k) for k, _ in node.value if k.tag != "tag:yaml.org,2002:merge"}
    loader.flatten_mapping(node)
    out = LocatedDict()
    out.file, out.line = loader.source_name, node.start_mark.line + 1
    own_keys = set()
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=True)
        if id(key_node) in own_nodes:
            if key in own_keys:
                raise ConfigError(f"duplicate key '{key}' (first at line {out.pos[key][1]})",
                                  f"{loader.source_name}:{key_node.start_mark.line + 1}")
            own_keys.add(key)
        out[key] = loader.construct_object(value_node, deep=True)
        out.pos[key] = (loader.source_name, key_node.start_mark.line + 1)
    return out


def _construct_sequence(loader: _Loader, node: yaml.SequenceNode):
    out = LocatedList(loader.construct_object(n, deep=True) for n in node.value)
    out.file, out.line = loader.source_name, node.start_mark.line + 1
    out.lines = [n.start_mark.line + 1 for n in node.value]
    return out


# YAML 1.1 (PyYAML) reads 1e6 and 1e-4 as strings; read them as floats, as YAML 1.2 does
_Loader.add_implicit_resolver("tag:yaml.org,2002:float",
                              re.compile(r"^[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"), list("-+0123456789"))
_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)
_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_SEQUENCE_TAG, _construct_sequence)


def load_yaml_text(text: str, source: str):
    try:
        loader = _Loader(text)
    except yaml.reader.ReaderError as e:      # the reader checks every character up front
        raise _unreadable(e, text, source) from None
    loader.source_name = source
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _expanded_size(node, source)
        return loader.construct_document(node)
    except yaml.MarkedYAMLError as e:
        mark = e.problem_mark or e.context_mark
        where = f"{source}:{mark.line + 1}" if mark else source
        raise ConfigError(f"invalid YAML: {e.problem or e.context}", where) from None
    except yaml.reader.ReaderError as e:
        raise _unreadable(e, text, source) from None
    except yaml.YAMLError as e:
        raise ConfigError(f"invalid YAML: {e}", source) from None
    except RecursionError:
        raise ConfigError(f"YAML nests too deeply to read (limit {MAX_DEPTH} levels)", source) from None
    except ValueError as e:          # a scalar Python cannot hold, e.g. an integer of more than 4300 digits
        raise ConfigError(f"invalid YAML value: {e}", source) from None
    finally:
        loader.dispose()


def _unreadable(e, text: str, source: str) -> ConfigError:
    char = e.character if isinstance(e.character, str) else chr(e.character)
    offset = len(text[:e.position].encode("utf-8", "surrogatepass"))
    line = text.count("\n", 0, e.position) + 1
    return ConfigError(f"character U+{ord(char):04X} at byte offset {offset} is not allowed in YAML text "
                       "(control characters: a binary file?)", f"{source}:{line}")


def read_text(path: str | Path, kind: str = "a YAML file") -> str:
    """The UTF-8 text of a file a user gives (``kind`` says what it should be, for the messages):
    a missing file, a folder, an unreadable or a binary/otherwise encoded one is a ConfigError naming
    the file (and, for bad bytes, the first one and its offset). Every text input reads through this."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise ConfigError("file not found", str(path)) from None
    except IsADirectoryError:
        raise ConfigError(f"is a folder, expected {kind}", str(path)) from None
    except OSError as e:
        raise ConfigError(f"cannot read the file: {e.strerror or e}", str(path)) from None
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ConfigError(f"not UTF-8 text: byte 0x{raw[e.start]:02x} at byte offset {e.start} ({e.reason}); "
                          f"{kind} is UTF-8 text (a binary file?)", str(path)) from None


def load_yaml(path: str | Path):
    path = Path(path)
    data = load_yaml_text(read_text(path, "a YAML file"), str(path))
    return LocatedDict() if data is None else data


def plain(obj):
    """Strip location info (for dumping / comparison)."""
    if isinstance(obj, dict):
        return {k: plain(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [plain(v) for v in obj]
    return obj


def dump_yaml(obj) -> str:
    return yaml.safe_dump(plain(obj), sort_keys=False, default_flow_style=None, width=100)
