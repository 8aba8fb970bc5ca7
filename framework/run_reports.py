"""Components' own end-of-run reports in the run's summary.

A component that defines ``report(cache, summary) -> dict | None`` contributes to the
run's ``summary.json``: after the run, ``Session.run`` calls it with the component's
per-run cache (what its ``make_cache`` returned, ``u.cache`` during the run) and the
simulator's summary so far (read it, do not change it), and puts a non-empty result under
``summary["reports"][component name]``. A component may also define a static
``format_report(report) -> list[str]``: the CLI prints those lines at the end of
``snakesim run`` (otherwise a compact JSON line). A report that raises is recorded as
``{"error": "..."}``, never failing the run. Pruned components are not asked.

A component that defines ``write_files(cache, out_dir) -> list[str]`` writes its own files into a
run's ``--out`` folder (a deformable terrain's state and a picture of its rut): called once the run has
ended, before the summary is written, which lists them under ``summary["files"][component name]``
(names relative to the folder). Unlike a report, a file that cannot be written fails the run: the user
asked for it (an OutputError naming the file; framework/output_files.py's writers).
"""

from __future__ import annotations

import json


def component_reports(plan, summary: dict) -> dict:
    """{component name: its report} for the plan's components that have a ``report`` method."""
    out = {}
    for name, comp in plan.components.items():       # pruned components are not in plan.components
        fn = getattr(comp, "report", None)
        if not callable(fn):
            continue
        try:
            rep = fn(plan.caches.get(name), summary)
        except Exception as e:          # a report never fails the run it reports on
            rep = {"error": f"{type(e).__name__}: {e}"}
        if rep:
            out[name] = rep
    return out


def add_reports(plan, summary: dict) -> None:
    """Put the components' reports into ``summary["reports"]`` (nothing when none reports)."""
    reps = component_reports(plan, summary)
    if reps:
        summary["reports"] = reps


def report_lines(plan, summary: dict) -> list[str]:
    """Terminal lines for ``summary["reports"]``: each component's ``format_report`` or one JSON line."""
    lines = []
    for name, rep in (summary.get("reports") or {}).items():
        fmt = getattr(plan.components.get(name), "format_report", None)
        try:
            body = fmt(rep) if callable(fmt) and "error" not in rep else [json.dumps(rep, default=float)]
        except Exception as e:
            body = [f"(report not formatted: {type(e).__name__}: {e})"]
        lines += [f"{name}:"] + [f"  {ln}" for ln in body]
    return lines


def write_component_files(plan, out_dir, summary: dict) -> None:
    """Call each component's ``write_files(cache, out_dir)``; list what each wrote in ``summary["files"]``."""
    files = {}
    for name, comp in plan.components.items():
        fn = getattr(comp, "write_files", None)
        if callable(fn):
            written = fn(plan.caches.get(name), out_dir)
            if written:
                files[name] = [str(w) for w in written]
    if files:
        summary["files"] = files
