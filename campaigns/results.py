"""A campaign's files: its identity, the append-only run records, and the results table.

``OUT/campaign.json``   what was asked (scene, overrides, dispersion file text, seed, N): a resumed
                        campaign must ask the same, or it is refused
``OUT/runs.jsonl``      one JSON line per finished run, appended and fsynced as each run finishes;
                        the only state a resume needs (a torn last line is ignored and rewritten)
``OUT/results.parquet`` the table, a row per finished run sorted by run index (pyarrow) ...
``OUT/results.csv``     ... and the same as CSV; both rebuilt from runs.jsonl, each written to a
                        temporary file and moved into place (``os.replace``), so a reader never
                        sees a half-written table
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from snakesim.framework.errors import SnakesimError
from snakesim.framework.output_files import append_line, make_dir, output_error, write_file

RECORDS = "runs.jsonl"
IDENTITY = "campaign.json"
FIRST_COLUMNS = ("run", "status", "outcome", "failure_kind", "reason", "stop_reason", "completed")
RUN_COLUMNS = ("sim_time_s", "wall_time_s", "real_time_factor", "steps", "build_s", "run_wall_s",
               "cpu_s", "session_reused", "worker")
# columns that differ between two executions of the same campaign (timing and placement)
TIMING_COLUMNS = ("wall_time_s", "real_time_factor", "build_s", "run_wall_s", "cpu_s", "session_reused", "worker")


class CampaignError(SnakesimError):
    """A campaign cannot start or resume (its folder, back end or input is wrong)."""


def atomic_write(path: Path, data: bytes | str) -> None:
    """Write ``path`` through a temporary file in the same folder and ``os.replace``
    (framework/output_files.py: a failure leaves no partial file and is an error naming the file)."""
    write_file(path, data)


def check_identity(out: Path, identity: dict, fresh: bool = False) -> bool:
    """Write OUT/campaign.json, or check it against an earlier one; True when resuming."""
    make_dir(out)
    path = out / IDENTITY
    if path.exists() and not fresh:
        try:
            old = json.loads(path.read_text())
        except OSError as e:
            raise output_error(path, e, "cannot read") from None
        except ValueError:
            raise CampaignError(f"{path} is not a campaign's JSON (a torn or foreign file); use another --out, "
                                f"or --fresh to start over") from None
        diff = [k for k in identity if old.get(k) != identity[k]]
        if diff:
            raise CampaignError(f"{out} holds a different campaign ({', '.join(diff)} differ); "
                                f"resume it with the same arguments, or use another --out (or --fresh to start over)")
        return True
    if fresh:
        for name in (RECORDS, "results.parquet", "results.csv"):
            try:
                (out / name).unlink(missing_ok=True)
            except OSError as e:
                raise output_error(out / name, e, "cannot remove") from None
    atomic_write(path, json.dumps(identity, indent=2, default=str))
    return False


class RecordLog:
    """The append-only run records: ``append`` as runs finish, ``load`` to resume."""

    def __init__(self, out: Path):
        self.path = Path(out) / RECORDS

    def load(self) -> dict[int, dict]:
        """Finished runs by index; the last record of a run wins; a torn last line is dropped from the file."""
        if not self.path.exists():
            return {}
        records, good_bytes = {}, 0
        with open(self.path, "rb") as fh:
            for line in fh:
                try:
                    rec = json.loads(line)
                    records[int(rec["run"])] = rec
                except (ValueError, KeyError, TypeError):
                    break           # the campaign was killed mid-write: everything after is lost
                good_bytes += len(line)
        if good_bytes != self.path.stat().st_size:
            try:
                with open(self.path, "r+b") as fh:
                    fh.truncate(good_bytes)
            except OSError as e:
                raise output_error(self.path, e, "cannot cut the torn last line of") from None
        return records

    def append(self, rec: dict) -> None:
        # one write of one line, then fsync: a kill leaves at most a torn last line, which load() drops
        # (a failed append is cut back: framework/output_files.py)
        append_line(self.path, json.dumps(rec, default=str) + "\n")


def _column_type(values):
    import pyarrow as pa

    present = [v for v in values if v is not None]
    if present and all(isinstance(v, bool) for v in present):
        return pa.bool_(), values
    if present and all(isinstance(v, int) and not isinstance(v, bool) for v in present):
        return pa.int64(), values
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        return pa.float64(), [None if v is None else float(v) for v in values]
    if all(isinstance(v, str) for v in present):
        return pa.string(), values
    # mixed or structured (a choice of lists or mappings): the value as JSON text
    return pa.string(), [None if v is None else json.dumps(v) for v in values]


def table_rows(records: dict[int, dict], param_paths: list[str]) -> tuple[list[str], list[dict], list[str]]:
    """Flatten records into (columns, rows, metric names): parameters, then metrics, then run columns."""
    metric_names: list[str] = []
    seen = set()
    for i in sorted(records):
        for k in records[i].get("metrics") or {}:
            if k not in seen:
                seen.add(k)
                metric_names.append(k)
    columns = list(FIRST_COLUMNS) + list(param_paths) + metric_names + list(RUN_COLUMNS)
    rows = []
    for i in sorted(records):
        r = records[i]
        row = {c: r.get(c) for c in FIRST_COLUMNS + RUN_COLUMNS}
        row.update({p: (r.get("parameters") or {}).get(p) for p in param_paths})
        row.update({m: (r.get("metrics") or {}).get(m) for m in metric_names})
        rows.append(row)
    return columns, rows, metric_names


def to_arrow(records: dict[int, dict], param_paths: list[str]):
    """The results table as a pyarrow Table (metadata: which columns are parameters and metrics)."""
    import pyarrow as pa

    columns, rows, metric_names = table_rows(records, param_paths)
    arrays, fields = [], []
    for c in columns:
        values = [row.get(c) for row in rows]
        if c in metric_names:
            typ, values = pa.float64(), [None if v is None else float(v) for v in values]
        else:
            typ, values = _column_type(values)
        arrays.append(pa.array(values, type=typ))
        fields.append(pa.field(c, typ))
    meta = {"snakesim.parameters": json.dumps(param_paths), "snakesim.metrics": json.dumps(metric_names)}
    return pa.Table.from_arrays(arrays, schema=pa.schema(fields, metadata=meta))


def write_table(out: Path, records: dict[int, dict], param_paths: list[str]):
    """Write OUT/results.parquet and OUT/results.csv (each atomically); returns the Table."""
    import io

    import pyarrow.csv as pcsv
    import pyarrow.parquet as pq

    table = to_arrow(records, param_paths)
    buf = io.BytesIO()
    pq.write_table(table, buf)
    atomic_write(Path(out) / "results.parquet", buf.getvalue())
    buf = io.BytesIO()
    pcsv.write_csv(table, buf)
    atomic_write(Path(out) / "results.csv", buf.getvalue())
    return table


def finite(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
