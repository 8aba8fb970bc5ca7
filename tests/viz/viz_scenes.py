"""Shared helpers: read a .rrd back with rerun's own reader, run the CLI."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

DATA = Path(__file__).parent / "data"
SCENE = DATA / "moulin-tether.yaml"


class Recording:
    """An .rrd file opened with rerun.chunk.RrdReader: entities, static flags, times, values."""

    def __init__(self, path):
        import rerun.chunk as rc

        self.path = Path(path)
        reader = rc.RrdReader(self.path)
        self.stores = reader.recordings()
        self.chunks = reader.stream().to_chunks()

    @property
    def entities(self) -> set[str]:
        return {c.entity_path for c in self.chunks if c.entity_path != "/__properties"}

    def columns(self, entity: str, name: str) -> tuple[np.ndarray, list]:
        """(sim times in s, values) of one component column, temporal chunks, time order."""
        times, values = [], []
        for c in self.chunks:
            if c.entity_path != entity or c.is_static:
                continue
            b = c.to_record_batch()
            if name not in b.schema.names:
                continue
            times += [d.total_seconds() for d in b.column("sim").to_pylist()]
            values += b.column(name).to_pylist()
        order = np.argsort(times, kind="stable")
        return np.asarray(times)[order], [values[i] for i in order]

    def static_columns(self, entity: str) -> set[str]:
        return {n for c in self.chunks if c.entity_path == entity and c.is_static
                for n in c.to_record_batch().schema.names}


@pytest.fixture
def read_rrd():
    return Recording


@pytest.fixture
def cli_runner():
    from click.testing import CliRunner

    from snakesim.framework.cli import cli, install_plugin_cli

    install_plugin_cli()

    def invoke(*args, env=None):
        return CliRunner().invoke(cli, [str(a) for a in args], env=env, catch_exceptions=False)

    return invoke
