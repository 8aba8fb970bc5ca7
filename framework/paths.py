"""One rule for file paths in assemblies: relative to the file that names them.

An ``include:`` is found relative to the including file; every other path (a multibody's
``urdf:``, a trajectory's ``file:``) follows the same rule, applied here rather than in each
component, so components receive absolute paths and a scene runs the same from any working
folder. A path given on the command line (``--urdf``, ``--set``) is relative to the current
folder, as a shell user expects.

How: strings read from an assembly or config file become :class:`LocatedStr`, a ``str`` that
remembers the folder of its file (:func:`locate_strings`, where the files are read). A template
``"${robot.urdf}"`` hands the parameter's own string on, so the parameter's file counts, not the
file holding the template. A component marks its path parameters with :data:`AssemblyPath`; before
the component validates its params, :func:`absolute_paths` turns each relative one into an
absolute path.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated, Callable

import yaml

#: what the command line and in-memory layers call their file: relative to the working folder
NOT_A_FILE = ("command line", None)


class LocatedStr(str):
    """A string from an assembly file; ``base`` is that file's folder (None: the working folder)."""

    base: str | None = None

    def __new__(cls, value: str, base: str | None):
        s = super().__new__(cls, value)
        s.base = base
        return s

    def __reduce__(self):
        return LocatedStr, (str(self), self.base)


# a LocatedStr is written to YAML as the plain string it is (config.yaml, reports)
yaml.SafeDumper.add_representer(LocatedStr, yaml.representer.SafeRepresenter.represent_str)
yaml.Dumper.add_representer(LocatedStr, yaml.representer.SafeRepresenter.represent_str)


def _base_of(file) -> str | None:
    if file in NOT_A_FILE or str(file).startswith("<"):
        return None
    return str(Path(file).resolve().parent)


def locate_strings(data):
    """``data`` (a loaded LocatedDict/LocatedList tree) with every string value a :class:`LocatedStr`
    remembering the folder of the file it was written in. Containers are changed in place."""
    if isinstance(data, dict):
        pos = getattr(data, "pos", {})
        for k, v in data.items():
            if isinstance(v, str) and not isinstance(v, LocatedStr):
                data[k] = LocatedStr(v, _base_of(pos.get(k, (getattr(data, "file", None),))[0]))
            else:
                locate_strings(v)
    elif isinstance(data, list):
        for i, v in enumerate(data):
            if isinstance(v, str) and not isinstance(v, LocatedStr):
                data[i] = LocatedStr(v, _base_of(getattr(data, "file", None)))
            else:
                locate_strings(v)
    return data


class _PathMarker:
    """Field metadata: this parameter is a file path (``is_path(value)`` says which strings are paths)."""

    def __init__(self, is_path: Callable[[str], bool] | None = None):
        self.is_path = is_path or (lambda value: True)


def assembly_path(is_path: Callable[[str], bool] | None = None) -> _PathMarker:
    """Marker for ``Annotated[str, assembly_path(...)]`` where only some strings are paths (a URDF field
    that also takes URDF text; a terrain field that also takes a name)."""
    return _PathMarker(is_path)


#: a parameter that is a file path, relative to the file that names it
AssemblyPath = Annotated[str, _PathMarker()]


def _marker(field) -> _PathMarker | None:
    return next((m for m in field.metadata if isinstance(m, _PathMarker)), None)


def absolute(value: str) -> str:
    """``value`` as an absolute path: from its file's folder (a LocatedStr) or the working folder."""
    if os.path.isabs(value):
        return str(value)
    base = getattr(value, "base", None) or os.getcwd()
    return os.path.normpath(os.path.join(base, os.path.expanduser(str(value))))


def absolute_paths(params_cls, params: dict) -> dict:
    """``params`` with every relative path in a field marked :data:`AssemblyPath` made absolute."""
    fields = getattr(params_cls, "model_fields", {})
    out = None
    for name, field in fields.items():
        marker = _marker(field)
        value = params.get(name) if isinstance(params, dict) else None
        if marker is None or not isinstance(value, str) or not value or not marker.is_path(value):
            continue
        out = dict(params) if out is None else out
        out[name] = absolute(value)
    return params if out is None else out
