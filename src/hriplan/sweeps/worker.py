"""Running one variant in a worker: derive, plan and validate every step as `hriplan plan` does.

A worker keeps one planning session per robot and hand postures for its whole life
(planner.session.worker_session), so robot loading and collision set-up happen once per worker,
not once per variant. Each step becomes one result row: the varied values, derived constraint
kinds, status and reason, planning time, path length, motion duration, the closest approach per
person and the worst speed-and-separation margin (when the trajectory report carries per-person
separation traces), and the trajectory itself when the sweep keeps them (--save-trajectories).
"""

from __future__ import annotations

import os
import socket
import time
from typing import Any

from hriplan import HriplanError
from hriplan.planner.outcome import Status
from hriplan.sweeps.variants import Variant

Row = dict[str, Any]


def variant_columns(variant: Variant) -> Row:
    """The row's identity: key, source, varied values (vectors one column per component), task."""
    row: Row = {"key": variant.key, "source": variant.source}
    for path, value in variant.values.items():
        if isinstance(value, list):
            row |= {f"vary.{path}.{i}": v for i, v in enumerate(value)}
        else:
            row[f"vary.{path}"] = value
    row["task"] = variant.task.model_dump_json(by_alias=True)  # the row alone reproduces the variant
    return row


def separation_columns(report: Any, people: list[str]) -> Row:
    """Closest approach per person, and the worst speed-and-separation margin if reported.

    With per-person separation traces (the report's `separation`), each person's own minimum;
    otherwise the trajectory's overall closest approach, credited to the person it was measured to."""
    row: Row = {f"min_separation.{p}": None for p in people}
    row["ssm_worst_margin"] = None
    if report is None:
        return row
    traces = getattr(report, "separation", None) or []
    if traces:
        for trace in traces:
            row[f"min_separation.{trace.person}"] = trace.min_separation
        margins = [t.worst_margin for t in traces if t.worst_margin is not None]
        row["ssm_worst_margin"] = min(margins) if margins else None
    elif report.min_human_distance is not None and report.closest_pair:
        person = report.closest_pair[1].split("/")[0]
        row[f"min_separation.{person}"] = report.min_human_distance
    return row


def run_variant(variant: Variant, plan: bool = True) -> list[Row]:
    """Every step of the variant as a row; a bad variant is one `error` row with the reason."""
    from hriplan.planner.session import worker_session
    from hriplan.robots.descriptions.registry import load_robot_file
    from hriplan.tasks.pipeline import TaskRunner

    began, cpu = time.perf_counter(), time.process_time()
    base = variant_columns(variant) | {"worker": f"{socket.gethostname()}:{os.getpid()}"}
    try:
        if variant.task.robot_file:  # a spawned worker knows the built-in robots only
            load_robot_file(variant.task.robot_file)
        session = worker_session(variant.task.robot, variant.task.hands) if plan else None
        outcome = TaskRunner(variant.task, session=session).run(plan=plan)
    except HriplanError as exc:
        timing = {"wall_time": time.perf_counter() - began, "cpu_time": time.process_time() - cpu}
        return [base | {"step": "", "step_index": -1, "status": Status.ERROR.value, "reason": str(exc)} | timing]
    timing = {
        "wall_time": time.perf_counter() - began,
        "cpu_time": time.process_time() - cpu,
    }  # per variant (all its steps)
    people = [h.name for h in variant.task.humans]
    rows = []
    for index, step in enumerate(outcome.steps):
        report = step.trajectory.report if step.trajectory is not None else None
        kinds = {c.kind for c in step.derivation.constraints} | {v.kind for v in step.derivation.velocity}
        rows.append(
            base
            | {
                "step": step.name,
                "step_index": index,
                "kind": step.kind,
                "status": Status(step.status).value,
                "reason": step.message,
                "constraint_kinds": ",".join(sorted(kinds)),
                "velocity_scale": step.derivation.velocity_scale,
                "planning_time": report.planning_time if report else None,
                "path_length": report.path_length if report else None,
                "duration": report.duration if report else None,
                "min_human_distance": report.min_human_distance if report else None,
            }
            | separation_columns(report, people)
            | timing
            | _trajectory(variant, step.trajectory)
        )
    return rows


def _trajectory(variant: Variant, trajectory: Any) -> Row:
    """The step's trajectory file's text, when the sweep keeps them (written by the driver)."""
    if not variant.trajectories or trajectory is None:
        return {}
    return {"trajectory": trajectory.text()}


def failure_rows(variant: Variant, reason: str) -> list[Row]:
    """The record of a variant no worker could finish (its worker died on every attempt)."""
    return [
        variant_columns(variant) | {"step": "", "step_index": -1, "status": Status.WORKER_DIED.value, "reason": reason}
    ]
