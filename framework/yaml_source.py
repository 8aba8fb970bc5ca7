"""YAML loading that remembers where every mapping key came from.

Mappings load as :class:`LocatedDict` (a plain dict plus ``file`` and the line
of each key), so a schema error deep inside an assembly can still be reported
as ``scene.yaml:14: components.pend.params.length``. Only safe YAML tags.
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


class _Loader(yaml.SafeLoader):
    pass


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
    loader = _Loader(text)
    loader.source_name = source
    try:
        return loader.get_single_data()
    except yaml.MarkedYAMLError as e:
        mark = e.problem_mark or e.context_mark
        where = f"{source}:{mark.line + 1}" if mark else source
        raise ConfigError(f"invalid YAML: {e.problem or e.context}", where) from None
    finally:
        loader.dispose()


def load_yaml(path: str | Path):
    path = Path(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise ConfigError("file not found", str(path)) from None
    except IsADirectoryError:
        raise ConfigError("is a folder, expected a YAML file", str(path)) from None
    data = load_yaml_text(text, str(path))
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
