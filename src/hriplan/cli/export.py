"""`hriplan export`: a task's planned steps as a ROS 2 bag (formats/rosbag.py)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hriplan import HriplanError


def _topics(items: list[str]) -> dict[str, str]:
    topics = {}
    for item in items:
        name, sep, topic = item.partition("=")
        if not sep or not name:
            raise HriplanError(
                f"--topic takes CONTROLLER=TOPIC (e.g. right_arm_controller=/right/joint_trajectory), got {item!r}"
            )
        topics[name] = topic
    return topics


def export(
    trajectories: Annotated[
        list[Path],
        typer.Argument(help="Trajectory files of `hriplan plan`, a task's steps in order.", show_default=False),
    ],
    output: Annotated[Path, typer.Option("-o", "--output", help="The bag to write (a directory).", show_default=False)],
    force: Annotated[bool, typer.Option("--force", help="Replace an existing bag.")] = False,
    topic: Annotated[
        list[str], typer.Option("--topic", help="CONTROLLER=TOPIC: another topic for a controller (repeatable).")
    ] = [],  # noqa: B006 - typer needs a literal default
) -> None:
    """Write trajectory files as a ROS 2 bag (MCAP): a trajectory_msgs/JointTrajectory topic per
    controller (each arm; each hand's finger joints at the step's posture), each step stamped
    with its start, and the whole motion as a moveit_msgs/DisplayTrajectory on /display_planned_path.

    \b
    Example:
      hriplan plan examples/handover_full_can.yaml -o out/can.json
      hriplan export out/can.take_can.json out/can.place_can.json out/can.place_can_release.json -o out/can_bag
    """
    from hriplan.cli.outputs import directory_output
    from hriplan.formats.rosbag import export_bag

    written = export_bag(trajectories, directory_output(output), force, _topics(topic))
    typer.echo(f"wrote {written.path} (rosbag2, MCAP storage): {len(trajectories)} step(s), {written.duration:.3f} s")
    for name, count in written.messages.items():
        typer.echo(f"  {name}: {count} message(s)")
