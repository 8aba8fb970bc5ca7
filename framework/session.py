"""One configured simulation: resolve -> build -> run, the path the CLI and tests share."""

from __future__ import annotations

import datetime
import json
from pathlib import Path

from pydantic import ValidationError

from .assembly import Resolved, resolve
from .errors import ConfigError, SnakesimError
from .builder import Builder
from .plan import Plan
from .registry import Registry, default_registry
from .run_reports import add_reports, write_component_files
from .validation_errors import config_error
from .run_files import in_progress_summary, prepare_out_dir, release_out_dir, write_error_summary
from .simulator import RunResult, Simulator, write_run
from .warm_up import close_after_run, open_before_run, warm_up
from .yaml_source import dump_yaml


def make_integrator(spec, registry: Registry):
    """The integrator an :class:`~.assembly.IntegratorSpec` names, with its parameters."""
    try:
        cls = registry.integrator(spec.name)
    except Exception as e:
        raise ConfigError(str(e), None, "sim.integrator.name") from None
    try:
        return cls(spec.params)
    except ValidationError as e:       # one line naming the key, the value and what is valid
        err = config_error(e, getattr(cls, "Params", None), key_prefix="sim.integrator.params")
        raise ConfigError(f"integrator '{spec.name}': {err.detail}", err.where, err.key) from None
    except Exception as e:
        raise ConfigError(f"bad parameters for integrator '{spec.name}': {e}", None, "sim.integrator.params") from None


class Session:
    def __init__(self, resolved: Resolved, registry: Registry | None = None, open_inputs=()):
        """``open_inputs``: (``component.input``, where) pairs left unconnected, set from outside
        (:func:`.simulation.load`)."""
        self.registry = registry or default_registry()
        self.resolved = resolved
        # the assembly as builder calls (one path for files and Python objects): the plan of framework/plan.py
        self.plan: Plan = Builder.from_resolved(resolved, self.registry, open_inputs).plan()
        self.integrator = make_integrator(resolved.sim.integrator, self.registry)
        self.simulator = Simulator(self.plan, self.integrator)
        warm_up(self.plan, self.integrator, resolved.sim.t0)      # compiled code loaded now, not in the run
        self.interrupted: dict | None = None

    # -- views ----------------------------------------------------------------
    def config_dict(self) -> dict:
        """The full resolved configuration, every parameter default filled in."""
        full = {n: c.p.model_dump(mode="json") for n, c in self.plan.components.items()}
        d = self.resolved.to_dict(full)
        d["sim"]["integrator"] = {"name": self.integrator.name, "params": self.integrator.p.model_dump(mode="json")}
        # pruned components are kept in the file: pruning is a build decision, not config
        return d

    def config_text(self) -> str:
        return "# snakesim resolved configuration: run again with `snakesim run THIS_FILE`\n" + dump_yaml(self.config_dict())

    def report(self, detail: bool = False, baseline: bool = False) -> dict:
        """The build report; ``detail`` adds each component's own ``build_report()``, ``baseline`` asks
        them for their costly extras too (``snakesim check --baseline``)."""
        r = dict(self.plan.report)
        r["integrator"] = self.integrator.name
        r["source"] = self.resolved.source
        if detail:
            extra = {n: c.build_report(baseline=baseline) for n, c in self.plan.components.items()}
            r["component_reports"] = {n: rep for n, rep in extra.items() if rep}
        return r

    # -- running ---------------------------------------------------------------
    def run(self, out_dir: Path | None = None, progress=None, realtime: bool | None = None) -> RunResult:
        """Run once; with ``out_dir`` (checked writable before the first step) write the run there. After
        :meth:`interrupt` the run ends at the next step boundary and its summary says so."""
        sim = self.resolved.sim
        if out_dir is not None:
            prepare_out_dir(out_dir, overwrite=True)        # claimed: one writer a folder (run_files.py)
            try:      # before the first step: a killed run keeps its config beside the signals streamed so far,
                (Path(out_dir) / "config.yaml").write_text(self.config_text())
                (Path(out_dir) / "last_good_state.npz").unlink(missing_ok=True)
                # and a summary that says the run is not finished (the finished run replaces it)
                (Path(out_dir) / "summary.json").write_text(
                    json.dumps(in_progress_summary(self.resolved.source), indent=2) + "\n")
            except OSError as e:
                release_out_dir(out_dir)
                raise SnakesimError(f"could not write the run to {out_dir}: {e}") from None
        closed = False
        try:
            open_before_run(self.plan, sim.t0)
            result = self.simulator.run(sim.duration, t0=sim.t0, progress=progress,
                                        realtime=sim.realtime if realtime is None else realtime, out_dir=out_dir)
            if self.interrupted is not None:
                result.summary["interrupted"] = {**self.interrupted, "at_sim_time_s": result.summary["t_end_s"]}
            add_reports(self.plan, result.summary)          # components' report(cache, summary): framework/run_reports.py
            # closed before the summary is written: a recorder that fails to finish its file (a full disk)
            # fails the run, and the summary must say so, not "success"
            closed = True
            close_after_run(self.plan)
            if out_dir is not None:
                write_component_files(self.plan, Path(out_dir), result.summary)     # run_reports.py
                write_run(Path(out_dir), result, self.config_text())
        except BaseException as e:     # KeyboardInterrupt too: the recorders still close their files
            if not closed:
                try:
                    close_after_run(self.plan)
                except Exception:       # noqa: BLE001 - the error already under way is the run's
                    pass
            if out_dir is not None:         # the folder says how the run ended, not "still running"
                write_error_summary(out_dir, self.resolved.source, e)
            raise
        finally:
            if out_dir is not None:
                release_out_dir(out_dir)
        return result

    def interrupt(self, signal_name: str) -> None:
        """Stop the run at the next step boundary (from a signal handler: SIGINT, SIGTERM); the summary gets
        ``interrupted: {signal, wall_clock, at_sim_time_s}``."""
        if self.interrupted is None:
            self.interrupted = {"signal": signal_name,
                                "wall_clock": datetime.datetime.now().astimezone().isoformat(timespec="seconds")}
        self.simulator.request_stop(f"interrupted by {signal_name}", "signal")


def load_session(assembly, *, config_files=(), overrides=(), sim_overrides=None,
                 registry: Registry | None = None) -> Session:
    registry = registry or default_registry()
    resolved = resolve(assembly, search_path=registry.assembly_paths(), config_files=config_files,
                       overrides=overrides, sim_overrides=sim_overrides)
    return Session(resolved, registry)
