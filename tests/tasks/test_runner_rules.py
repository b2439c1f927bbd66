"""A task runner reads the rule files once for all the situations it derives, and a new runner
reads them again: a rule file changed between two runs is the one the second run derives with."""

from pathlib import Path

from hriplan.api import load_task
from hriplan.tasks import pipeline
from hriplan.tasks.pipeline import TaskRunner

EXAMPLE = Path(__file__).parents[2] / "examples" / "handover_full_can_receiver.yaml"
SLOW_CANS = (
    "[slow_cans] TransportingTask(?t) ^ movesObject(?t, ?o) ^ Can(?o) -> isConstrainedBy(?o, ReducedVelocityHot)\n"
)


def test_one_read_of_the_rules_per_runner_and_an_edited_file_read_by_the_next(tmp_path, monkeypatch):
    rules = tmp_path / "user.rules"
    rules.write_text("# Slows every can carried.\n" + SLOW_CANS)
    task = load_task(EXAMPLE).model_copy(update={"rule_files": [str(rules)]})
    reads, bases = [], []
    loading, knowing = pipeline.load_rules, pipeline.KnowledgeBase
    monkeypatch.setattr(pipeline, "load_rules", lambda files: reads.append(list(files)) or loading(files))
    monkeypatch.setattr(pipeline, "KnowledgeBase", lambda *a, **k: bases.append(knowing(*a, **k)) or bases[-1])

    first = TaskRunner(task).run(plan=False)
    (step,) = first.steps
    assert len(bases) == 2  # the grasp choice's situation and the step's (the grasp chosen)
    assert reads == [[str(rules.resolve())]] and bases[0].rules == bases[1].rules == loading([rules])
    assert step.derivation.velocity_scale == 0.5
    assert [v.rules for v in step.derivation.velocity if v.kind == "ReducedVelocityHot"] == [["slow_cans"]]

    rules.write_text("# No longer.\n")
    second = TaskRunner(task).run(plan=False)
    assert len(reads) == 2 and second.steps[0].derivation.velocity_scale == 1.0
