"""How a run ended: success or failure, the kind of failure, and the exit code of each kind.

Every run ends in one of two outcomes. ``success``: the run reached its duration, or a stop that
declares itself a success ended it (a scene's ``stop:`` entry with ``outcome: success``, a
component's ``self.stop(reason, outcome="success")``: an evaluation that reached its goal).
``failure``: anything else, with one kind that says what went wrong; ``snakesim run`` exits with that
kind's code (the one table below; README.md and docs/architecture.md quote it).

Codes 1 and 2 are click's (an error before or around the run: bad configuration, unwritable
``--out``; a usage error), 3 was the single code of every blow-up before the kinds were told apart
and is not used any more (a script that tested for it now sees 13-16), 128 + N is an interrupt by
signal N (SIGINT 130, SIGTERM 143). The failure kinds take 10-17, clear of all of those and of
the shell's 126/127; 20 is ``snakesim sweep``'s "at least one run was not a success".

Nothing here imports numpy: the CLI reads the table without loading the simulator.
"""

from __future__ import annotations

SUCCESS, FAILURE = "success", "failure"
OUTCOMES = (SUCCESS, FAILURE)

#: failure kind -> (exit code of ``snakesim run``, what it means)
FAILURE_KINDS: dict[str, tuple[int, str]] = {
    "stop_rule": (10, "a scene's stop: entry (outcome: failure, the default) held"),
    "guard": (11, "a component's guard stopped the run (contact deeper than max_depth, a joint past its "
                  "limits, a link inside the terrain, a placement that did not settle, a gate held too long)"),
    "mobility": (12, "a mobility monitor judged the robot lost (tilted past max_tilt)"),
    "blow_up": (13, "the multibody's kinetic energy rose by more than the actuators, gravity and the external "
                    "wrenches can supply in one step (blow-up guard)"),
    "non_finite": (14, "a non-finite (NaN, inf) state, recorded output or output read by a sink"),
    "integrator": (15, "the integrator failed (a singular matrix, a step size collapsing)"),
    "numerical": (16, "a component's evaluation raised a LinAlgError or FloatingPointError"),
    "memory_limit": (17, "the recording reached its memory limit: the run could not complete"),
}
#: an interrupt (SIGINT, SIGTERM): a failure to complete, exit code 128 + the signal's number
INTERRUPTED = "interrupted"
#: ``snakesim sweep``: every run finished and at least one run's status is not in the dispersion
#: file's ``success`` list (default: ``ok``)
SWEEP_RUN_FAILED = 20
#: the code ``snakesim run`` used for every blow-up before the kinds were told apart; never returned now
RETIRED_BLOW_UP = 3


def exit_code_of(kind: str) -> int:
    """The exit code of failure ``kind`` (KeyError for an unknown one)."""
    return FAILURE_KINDS[kind][0]


def check_stop(outcome: str, kind: str | None, default_kind: str) -> str | None:
    """The failure kind a stop with ``outcome`` and ``kind`` records (None for a success); ValueError
    for an outcome other than success/failure, an unknown kind, or a kind given with a success."""
    if outcome not in OUTCOMES:
        raise ValueError(f"stop outcome must be 'success' or 'failure', got {outcome!r}")
    if outcome == SUCCESS:
        if kind is not None:
            raise ValueError(f"a successful stop has no failure kind (got {kind!r})")
        return None
    kind = default_kind if kind is None else kind
    if kind not in FAILURE_KINDS:       # "interrupted" is the simulator's (request_stop), not a component's
        raise ValueError(f"unknown failure kind {kind!r}; valid: {', '.join(FAILURE_KINDS)}")
    return kind


def run_exit_code(summary: dict) -> int:
    """``snakesim run``'s exit status for a run's summary: 0 on success, 128 + N after signal N, else
    the failure kind's code."""
    if summary.get("outcome", SUCCESS) == SUCCESS:
        return 0
    if summary.get("failure_kind") == INTERRUPTED:
        import signal

        # a stop requested without a signal (an embedding caller's request_stop) counts as Ctrl-C
        name = (summary.get("interrupted") or {}).get("signal", "SIGINT")
        return 128 + int(getattr(signal, name))
    return exit_code_of(summary["failure_kind"])


def exit_codes_help() -> str:
    """One line for ``snakesim run --help``: '10 stop_rule, 11 guard, ...'."""
    return ", ".join(f"{code} {kind}" for kind, (code, _) in FAILURE_KINDS.items())


def table_markdown() -> str:
    """The exit-code table as Markdown (what README.md and docs/architecture.md show; a test compares)."""
    rows = ["| exit code | `failure_kind` | meaning |", "|---|---|---|",
            "| 0 | (none: `outcome: success`) | the run reached its duration or a success stop |"]
    rows += [f"| {code} | `{kind}` | {what} |" for kind, (code, what) in FAILURE_KINDS.items()]
    rows.append(f"| 128 + N | `{INTERRUPTED}` | interrupted by signal N (SIGINT 130, SIGTERM 143); the run is "
                "written up to the step it stopped at |")
    return "\n".join(rows)
