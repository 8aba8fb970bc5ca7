"""Run monitors: mobility failure detection and climbing-test metrics (paper 4.3.1)."""

from .mobility import MobilityMonitor

__all__ = ["MobilityMonitor", "reference_link"]


def reference_link(component, name: str | None) -> tuple[int, str]:
    """(row, name) of the link a monitor follows: ``name``, or the robot's root link when None;
    an unknown name is a ValueError naming the component and the valid links."""
    links = list(component.robot.links)
    ref = name if name is not None else links[0]
    if ref not in links:
        raise ValueError(f"{component.name}: reference_link '{ref}' is not a link; links: {', '.join(links)}")
    return links.index(ref), ref
