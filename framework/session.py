"""One configured simulation: resolve -> build -> run, the path the CLI and tests share."""

from __future__ import annotations

from pathlib import Path

from .assembly import Resolved, resolve
from .errors import ConfigError
from .plan import Plan, build
from .registry import Registry, default_registry
from .simulator import RunResult, Simulator, write_run
from .yaml_source import dump_yaml


class Session:
    def __init__(self, resolved: Resolved, registry: Registry | None = None):
        self.registry = registry or default_registry()
        self.resolved = resolved
        self.plan: Plan = build(resolved, self.registry)
        spec = resolved.sim.integrator
        try:
            cls = self.registry.integrator(spec.name)
        except Exception as e:
            raise ConfigError(str(e), None, "sim.integrator.name") from None
        try:
            self.integrator = cls(spec.params)
        except Exception as e:
            raise ConfigError(f"bad parameters for integrator '{spec.name}': {e}", None, "sim.integrator.params") from None
        self.simulator = Simulator(self.plan, self.integrator)

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

    def report(self, detail: bool = False) -> dict:
        """The build report; ``detail`` adds each component's own ``build_report()``."""
        r = dict(self.plan.report)
        r["integrator"] = self.integrator.name
        r["source"] = self.resolved.source
        if detail:
            extra = {n: c.build_report() for n, c in self.plan.components.items()}
            r["component_reports"] = {n: rep for n, rep in extra.items() if rep}
        return r

    # -- running ---------------------------------------------------------------
    def run(self, out_dir: Path | None = None, progress=None, realtime: bool | None = None) -> RunResult:
        sim = self.resolved.sim
        result = self.simulator.run(sim.duration, t0=sim.t0, progress=progress,
                                    realtime=sim.realtime if realtime is None else realtime)
        if out_dir is not None:
            write_run(Path(out_dir), result, self.config_text())
        return result


def load_session(assembly, *, config_files=(), overrides=(), sim_overrides=None,
                 registry: Registry | None = None) -> Session:
    registry = registry or default_registry()
    resolved = resolve(assembly, search_path=registry.assembly_paths(), config_files=config_files,
                       overrides=overrides, sim_overrides=sim_overrides)
    return Session(resolved, registry)
