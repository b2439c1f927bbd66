"""What `hriplan plan` and `hriplan constraints` print: short, one line per constraint."""

from __future__ import annotations

from hriplan.planner.constraints.words import describe
from hriplan.rules.infer import Derivation
from hriplan.safety.report import SeparationTrace
from hriplan.tasks.pipeline import TaskOutcome


def constraint_lines(derivation: Derivation) -> list[str]:
    lines = [
        f"  {c.spec.id:34s} {c.spec.type:11s} {describe(c.spec)}\n  {'':34s} why: {c.reason}"
        for c in derivation.constraints
    ]
    lines += [f"  velocity scale {v.value:g} ({v.anchor}): {v.reason}" for v in derivation.velocity]
    return lines


# A sample whose speed towards a person is this close to the allowed one was slowed by it.
BINDING = 0.98


def separation_phrase(trace: SeparationTrace) -> str:
    """How a person's speed limit shaped the motion, e.g. 'slowed to 0.74 m/s within 0.20 m of alice':
    the lowest limit the robot was held to, and the largest separation at which a limit held it."""
    binding = [
        (allowed, separation)
        for allowed, approach, separation in zip(trace.allowed_speed, trace.approach_speed, trace.separation)
        if allowed is not None and approach is not None and approach > 0.0 and approach >= BINDING * allowed
    ]
    if binding:
        return f"slowed to {min(b[0] for b in binding):.2f} m/s within {max(b[1] for b in binding):.2f} m of {trace.person}"
    margin = "" if trace.worst_margin is None else f", speed margin >= {trace.worst_margin:.2f} m/s"
    return f"not slowed near {trace.person}{margin}"


def summarize(outcome: TaskOutcome, verbose: bool = False) -> str:
    lines = [f"task {outcome.task}: {len(outcome.steps)} step(s)"]
    for step in outcome.steps:
        head = f"step {step.name} ({step.kind}, {'/'.join(step.arms)} arm): {step.status}"
        traj = step.trajectory
        if traj is not None and len(traj.points) == 1:
            head += f": {step.message}"
        elif traj is not None:
            report = traj.report
            distance = (
                f", closest to a person {report.min_human_distance:.3f} m"
                if report.min_human_distance is not None
                else ""
            )
            head += (
                f" in {report.planning_time:.2f} s, path {report.path_length:.2f} rad, "
                f"motion {report.duration:.2f} s at velocity scale {report.velocity_scale:g}{distance}"
            )
            head += "".join(f"; {separation_phrase(t)}" for t in report.separation)
        elif step.message:
            head += f": {step.message}"
        lines.append(head)
        lines += constraint_lines(step.derivation)
        if verbose and traj is not None:
            lines += [f"  worst margin {k}: {v:+.4f}" for k, v in traj.report.max_violation.items()]
            lines.append(f"  constraint calls: {traj.report.calls}")
    return "\n".join(lines)
