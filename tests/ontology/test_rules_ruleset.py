"""The rule-file format: parsing, errors with file and line, package rules, user rule files."""

import pytest

from hriplan import HriplanError
from hriplan.ontology.cache import ReasoningCache
from hriplan.ontology.knowledge_base import KnowledgeBase
from hriplan.ontology.ruleset import Atom, Name, Var, load_rules, parse_rules
from hriplan.ontology.situation import EXAMPLES_DIR, Situation, load_situation
from hriplan.rules.infer import infer_constraints

GOOD = """\
# File header: not a rationale, a blank line follows.

# Rationale, line one,
# and line two.
[first_rule] Can(?o) ^ hasX(?o, ?x) ^ swrlb:lessThan(?x, 0.5)
    -> isConstrainedBy(?o, UprightFull)
# Second rationale.
[second_rule] Human(?h) ^ hasRole(?h, "Receiver") ^ isOpen(?h, true) -> isNear(?h, ?h)
"""


def test_a_rule_file_parses_into_named_rules_with_rationales():
    first, second = parse_rules(GOOD, "good.rules")
    assert (first.name, first.rationale, first.source) == (
        "first_rule",
        "Rationale, line one, and line two.",
        "good.rules:5",
    )
    assert first.body == (
        Atom("Can", (Var("o"),)),
        Atom("hasX", (Var("o"), Var("x"))),
        Atom("lessThan", (Var("x"), 0.5), builtin=True),
    )
    assert first.head == (Atom("isConstrainedBy", (Var("o"), Name("UprightFull"))),)
    assert second.body[1].args == (Var("h"), "Receiver") and second.body[2].args == (Var("h"), True)
    assert first.swrl() == "Can(?o), hasX(?o, ?x), lessThan(?x, 0.5) -> isConstrainedBy(?o, UprightFull)"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[no_rationale] Can(?o) -> isNear(?o, ?o)", "needs a '#' comment line"),
        ("# r\n[bad name] Can(?o) -> isNear(?o, ?o)", "must be letters"),
        ("# r\n[two_arrows] Can(?o) -> Can(?o) -> Can(?o)", "exactly one '->'"),
        ("# r\n[unbound] Can(?o) -> isNear(?o, ?h)", r"head variables \?h do not occur in the body"),
        ("# r\n[bad_atom] Can ?o -> isNear(?o, ?o)", "cannot read atom"),
        ("# r\n[arity] hasX(?o, ?x, ?y) -> Can(?o)", "classes take 1, properties 2"),
        ("# r\n[builtin_head] Can(?o) -> swrlb:add(?o, 1, 2)", "built-ins belong in the body"),
        ("# r\n[empty] Can(?o) ^ -> Can(?o)", "empty atom"),
        ("just some text", "expected '# rationale'"),
    ],
)
def test_malformed_rules_are_one_line_errors_with_file_and_line(text, message):
    with pytest.raises(HriplanError, match=message) as info:
        parse_rules(text, "bad.rules")
    assert str(info.value).startswith("bad.rules:") and "\n" not in str(info.value)


def test_package_rules_cover_the_six_situations_and_have_rationales():
    names = {r.name for r in load_rules()}
    assert {
        "upright_full_open_container",
        "upright_partially_full_open_container",
        "handover_approach_cone",
        "handover_shared_workspace",
        "handover_receiver_exclusion",
        "keep_out_supervisor",
        "keep_out_bystander",
        "insertion_alignment",
        "sharp_end_away_from_receiver",
        "slow_fragile_object_near_human",
        "slow_hot_object_near_human",
    } <= names
    assert all(r.rationale for r in load_rules())


def test_rule_names_must_be_unique_across_files(tmp_path):
    clash = tmp_path / "clash.rules"
    clash.write_text("# again\n[keep_out_supervisor] Human(?h) -> isNear(?h, ?h)\n")
    with pytest.raises(HriplanError, match="'keep_out_supervisor' is already used at .*humans.rules"):
        load_rules([clash])


def test_a_missing_rule_file_is_a_clear_error(tmp_path):
    with pytest.raises(
        HriplanError, match=r"nothing.rules: no such file"
    ):  # one reader for every user file (files.read_text)
        load_rules([tmp_path / "nothing.rules"])


def test_a_rule_naming_an_unknown_term_fails_before_reasoning(tmp_path):
    rules = tmp_path / "typo.rules"
    rules.write_text("# typo in a class name\n[typo] Cann(?o) -> isConstrainedBy(?o, UprightFull)\n")
    with pytest.raises(HriplanError, match=r"typo.rules:2: rule 'typo': 'Cann' is not a class or property"):
        KnowledgeBase(load_situation(EXAMPLES_DIR / "pouring.json"), rule_files=[rules], cache=ReasoningCache(None))


def test_a_user_rule_file_adds_a_constraint_without_python(tmp_path):
    rules = tmp_path / "bowls.rules"
    rules.write_text(
        "# A bowl is open and wide: even empty, it is carried upright so nothing on it slides off.\n"
        "[upright_any_bowl] TransportingTask(?t) ^ movesObject(?t, ?o) ^ Bowl(?o) -> isConstrainedBy(?o, UprightPartial)\n"
    )
    pouring = load_situation(EXAMPLES_DIR / "pouring.json")
    task = {"kind": "Transport", "arms": ["right"], "carries": {"bowl1": "right"}}
    situation = Situation.model_validate({**pouring.model_dump(), "task": task})
    cache = ReasoningCache(tmp_path / "cache")
    assert infer_constraints(situation, cache=cache) == []
    (derived,) = infer_constraints(situation, rule_files=[rules], cache=cache)
    assert derived.spec.id == "upright_bowl1" and derived.rules == ["upright_any_bowl"]
    assert derived.reason.startswith("A bowl is open and wide")
