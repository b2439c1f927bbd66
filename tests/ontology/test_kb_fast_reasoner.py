"""The in-process reasoner against Pellet, and reasoning keyed by the qualitative situation.

Every situation of the corpus (the example situations, every step of the example tasks, the
variants the tests build) is derived both ways: the facts, the constraints and their provenance
must be identical. Pellet's results come from the shared content-hashed cache (they are Pellet's
conclusions for exactly these facts); the in-process side never uses a cache.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

from hriplan import HriplanError
from hriplan.ontology import rule_engine
from hriplan.ontology.cache import ReasoningCache, default_cache
from hriplan.ontology.knowledge_base import KnowledgeBase
from hriplan.ontology.pellet import InconsistentSituation, run_pellet
from hriplan.ontology.situation import EXAMPLES_DIR, Situation, load_situation
from hriplan.ontology.vocabulary import ONTOLOGY_PATH
from hriplan.rules.infer import derive
from hriplan.tasks.load import load_task
from hriplan.tasks.pipeline import TaskRunner

EXAMPLE_TASKS = Path(__file__).resolve().parents[2] / "examples"


def example(name: str) -> Situation:
    return load_situation(EXAMPLES_DIR / f"{name}.json")


def moved(situation: Situation, person: str, dx: float, dy: float = 0.0) -> Situation:
    humans = [
        h.model_copy(update={"position": (h.position[0] + dx, h.position[1] + dy)}) if h.name == person else h
        for h in situation.humans
    ]
    return situation.model_copy(update={"humans": humans})


def with_object(situation: Situation, name: str, **update: object) -> Situation:
    objects = [o.model_copy(update=update) if o.name == name else o for o in situation.objects]
    return situation.model_copy(update={"objects": objects})


def _task_steps() -> list[tuple[str, Situation]]:
    found = []
    for path in sorted(EXAMPLE_TASKS.glob("*.yaml")):
        if str(yaml.safe_load(path.read_text()).get("robot", "")).endswith(".yaml"):
            continue  # a robot file registers its robot for good at collection (known robots: madar, ur5)
        runner = TaskRunner(load_task(path), path.parent)
        runner.run(plan=False)
        found += [(f"{path.stem}:{step}", kb.situation) for step, kb in runner.knowledge_bases.items()]
    return found


def _variants() -> list[tuple[str, Situation]]:
    handover, hot = example("handover_can"), example("transport_hot_cup")
    return [
        ("handover closed can", with_object(handover, "can1", open=False)),
        (
            "handover full and empty (inconsistent)",
            handover.model_copy(update={"facts": [("can1", "hasFillLevel", "Empty")]}),
        ),
        ("handover hot glass fact", handover.model_copy(update={"facts": [("glass1", "isHot", True)]})),
        ("hot cup, col walks away", moved(hot, "col", 1.0, 1.0)),
        (
            "hot cup, col walks away, path passes col",
            with_object(moved(hot, "col", 1.0, 1.0), "cup1", path=[(1.2, 1.6, 1.0), (0.9, 0.9, 0.9)]),
        ),
        (
            "knife handed over, knife not sharp (inconsistent)",
            with_object(example("handover_knife_glass"), "knife1", sharp=False),
        ),
        (
            "a can near a glass (inconsistent: isNear's range is Human)",
            handover.model_copy(update={"facts": [("can1", "isNear", "glass1")]}),
        ),
        (
            "performed by two robots (inconsistent: their functional URDF names differ)",
            handover.model_copy(update={"facts": [("handover", "performedBy", "ur5")]}),
        ),
    ]


CORPUS = [(p.stem, load_situation(p)) for p in sorted(EXAMPLES_DIR.glob("*.json"))] + _task_steps() + _variants()


@pytest.mark.parametrize(("label", "situation"), CORPUS, ids=[label for label, _ in CORPUS])
def test_in_process_and_pellet_conclude_the_same(label, situation):
    try:
        pellet = KnowledgeBase(situation, cache=default_cache(), reasoner="pellet")
    except InconsistentSituation as clash:  # the fast reasoner hands contradictions to Pellet
        with pytest.raises(InconsistentSituation) as info:
            KnowledgeBase(situation, cache=ReasoningCache(None), reasoner="fast")
        assert str(info.value) == str(clash)
        return
    fast = KnowledgeBase(situation, cache=ReasoningCache(None), reasoner="fast")
    assert fast.facts == pellet.facts
    assert outcome(fast) == outcome(pellet)  # constraints, velocity scales, rules, facts, reasons


def outcome(kb: KnowledgeBase) -> object:
    """The derivation, or the one-line error deriving it gives."""
    try:
        return derive(kb)
    except HriplanError as exc:
        return str(exc)


def test_the_corpus_makes_every_rule_fire():
    """Agreement means something only where rules fire: every packaged rule is in some provenance."""
    fired: set[str] = set()
    for _, situation in (entry for entry in CORPUS if "(" not in entry[0]):
        derivation = derive(KnowledgeBase(situation, cache=ReasoningCache(None)))
        fired |= {r for d in [*derivation.constraints, *derivation.velocity] for r in d.rules}
    packaged = {r.name for r in KnowledgeBase(example("pouring"), cache=ReasoningCache(None)).rules}
    # EmptyContainer is read by no rule, and the grasp rules conclude requiresGrasp, which no
    # constraint cites: only the facts show them, and they are compared too.
    assert packaged - fired == {"define_empty_container", "side_grasp_full_open_container", "handle_grasp_sharp_tool"}
    assert "carried_object_near_human" in fired


@pytest.fixture
def runs(monkeypatch) -> list[int]:
    """Counts in-process reasoner runs."""
    counted: list[int] = []
    original = rule_engine.reason

    def counting(*args, **kwargs):
        counted.append(1)
        return original(*args, **kwargs)

    monkeypatch.setattr("hriplan.ontology.knowledge_base.reason", counting)
    return counted


def test_moving_a_person_without_crossing_a_threshold_reuses_the_conclusions(runs):
    cache, hot = ReasoningCache(None), example("transport_hot_cup")
    cup = hot.object("cup1")
    derivations = []
    for step in range(5):  # col moves 10 cm at a time, staying within NearHuman of the cup
        situation = moved(hot, "col", 0.1 * step)
        col = situation.human("col")
        assert math.dist(cup.pose.xyz[:2], col.position) < 1.2
        derivations.append(derive(KnowledgeBase(situation, cache=cache)))
    assert len(runs) == 1  # one reasoner run for five geometries
    distances = [math.dist(cup.pose.xyz[:2], moved(hot, "col", 0.1 * s).human("col").position) for s in range(5)]
    for derivation, distance in zip(derivations, distances):  # the explanation follows the current geometry
        (hot_cup,) = derivation.velocity
        assert f"cup1 is {distance:.2f} m from col, below NearHuman 1.2 m" in hot_cup.facts


def test_crossing_the_threshold_changes_the_derivation(runs):
    cache, hot = ReasoningCache(None), example("transport_hot_cup")
    near = derive(KnowledgeBase(hot, cache=cache))
    away = moved(hot, "col", 1.0, 1.0)  # 1.0 m further along x and y: beyond 1.2 m from the cup
    assert math.dist(away.object("cup1").pose.xyz[:2], away.human("col").position) > 1.2
    far = derive(KnowledgeBase(away, cache=cache))
    assert near.velocity_scale == 0.5 and far.velocity_scale == 1.0 and far.velocity == []
    assert len(runs) == 2


def test_nearness_along_a_path_is_the_closest_approach_and_names_it():
    hot = moved(example("transport_hot_cup"), "col", 1.0, 1.0)
    col = hot.human("col")
    x, y, z = hot.object("cup1").pose.xyz
    # the cup's path runs past col 0.5 m to their side: a segment whose end points are both far from col
    path = [(col.position[0] - 1.0, col.position[1] + 0.5, z), (col.position[0] + 1.0, col.position[1] + 0.5, z)]
    assert min(math.dist(p[:2], col.position) for p in [(x, y), *path]) > 1.1
    derivation = derive(KnowledgeBase(with_object(hot, "cup1", path=path), cache=ReasoningCache(None)))
    (slow,) = derivation.velocity
    assert slow.kind == "ReducedVelocityHot" and "carried_object_near_human" in slow.rules
    assert "cup1 comes within 0.50 m of col along its path, below NearHuman 1.2 m" in slow.facts


def test_the_threshold_is_read_from_the_ontology(tmp_path):
    text = ONTOLOGY_PATH.read_text()
    assert text.count("hp:hasDistance 1.2 .") == 1
    ontology = tmp_path / "hriplan.ttl"
    ontology.write_text(text.replace("hp:hasDistance 1.2 .", "hp:hasDistance 0.5 ."))
    hot = example("transport_hot_cup")  # cup1 is 0.71 m from col
    assert derive(KnowledgeBase(hot, cache=ReasoningCache(None))).velocity_scale == 0.5
    assert derive(KnowledgeBase(hot, ontology=ontology, cache=ReasoningCache(None))).velocity_scale == 1.0


def test_what_the_fast_reasoner_cannot_evaluate_is_a_clear_error(tmp_path):
    ontology = tmp_path / "hriplan.ttl"
    ontology.write_text(ONTOLOGY_PATH.read_text() + "\nhp:Cup owl:equivalentClass hp:Bowl .\n")
    with pytest.raises(
        HriplanError,
        match=r"^the fast reasoner does not handle owl:equivalentClass on Cup in the ontology; use --reasoner pellet$",
    ):
        KnowledgeBase(example("pouring"), ontology=ontology, cache=ReasoningCache(None), reasoner="fast")
    rules = tmp_path / "strings.rules"
    rules.write_text('# Needs a string built-in.\n[named] Cup(?o) ^ swrlb:startsWith("cup", "c") -> isHot(?o, true)\n')
    with pytest.raises(
        HriplanError, match=r"rule 'named' uses built-in startsWith, which the fast reasoner does not evaluate"
    ):
        KnowledgeBase(example("pouring"), rule_files=[rules], cache=ReasoningCache(None), reasoner="fast")


@pytest.mark.parametrize(("flag", "pellet_runs"), [([], 0), (["--reasoner", "fast"], 0), (["--reasoner", "pellet"], 1)])
def test_the_cli_selects_the_reasoner(monkeypatch, tmp_path, flag, pellet_runs):
    from typer.testing import CliRunner

    from hriplan.cli.main import app
    from hriplan.ontology.reasoners import use_reasoner

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))  # nothing cached: the chosen reasoner must run
    ran: list[int] = []
    monkeypatch.setattr("hriplan.ontology.pellet.run_pellet", lambda world: ran.append(1) or run_pellet(world))
    try:
        result = CliRunner().invoke(
            app, ["constraints", str(EXAMPLE_TASKS / "transport_cup_bystander.yaml"), "-q", *flag]
        )
    finally:
        use_reasoner("fast")
    assert len(ran) == pellet_runs
    assert result.exit_code == 0, result.output
    assert "keep_out_dana" in result.output and "upright_cup" in result.output


FIELD_OF_VIEW = """
hp:isInFrontOf a owl:ObjectProperty ; rdfs:domain hp:PhysicalObject ; rdfs:range hp:Human ;
    rdfs:label "is in front of" ; rdfs:comment "Within the person's field of view." .
hp:hasHalfAngle a owl:DatatypeProperty , owl:FunctionalProperty ; rdfs:subPropertyOf hp:hasParameter ;
    rdfs:label "has half angle" ; rdfs:comment "Half the opening angle (rad)." .
hp:FieldOfView a owl:NamedIndividual , hp:ProximityCriterion ; rdfs:label "field of view" ; hp:hasHalfAngle 0.6 .
"""


def _bearings(situation: Situation):
    from hriplan.ontology.relations import Measurement
    from hriplan.rules.geometry import bearing

    for name in situation.task.carries:
        obj = situation.object(name)
        for human in situation.humans:
            yield Measurement(
                name, human.name, abs(bearing(human.position, human.yaw, obj.pose.xyz[:2], human.name)), False
            )


def test_a_new_relation_is_a_relation_kind_a_threshold_in_the_ontology_and_a_rule(tmp_path):
    from hriplan.ontology.relations import NEAR_HUMAN, RelationKind

    ontology, rules = tmp_path / "hriplan.ttl", tmp_path / "seen.rules"
    ontology.write_text(ONTOLOGY_PATH.read_text() + FIELD_OF_VIEW)
    rules.write_text(
        "# What someone sees coming is handled gently.\n"
        "[seen_object] Task(?t) ^ movesObject(?t, ?o) ^ isInFrontOf(?o, ?h) -> isConstrainedBy(?o, ReducedVelocityFragile)\n"
    )
    in_front = RelationKind(
        "object_in_front_of_human", "isInFrontOf", "FieldOfView", "hasHalfAngle", _bearings, unit="rad"
    )
    hot = example("transport_hot_cup")
    expected = set()  # independently: the angle between where each person faces and each carried object
    for obj in ("cup1", "bottle1"):
        for human in hot.humans:
            (x, y, _), (px, py) = hot.object(obj).pose.xyz, human.position
            off = math.remainder(math.atan2(y - py, x - px) - human.yaw, math.tau)
            if abs(off) < 0.6:
                expected.add((obj, human.name))
    assert expected == {("cup1", "col"), ("bottle1", "col")}  # ann, facing +x, sees neither
    kinds = [NEAR_HUMAN, in_front]
    fast = KnowledgeBase(
        hot, ontology=ontology, rule_files=[rules], relations=kinds, cache=ReasoningCache(None), reasoner="fast"
    )
    assert {(s, o) for s, p, o in fast.assertions if p == "isInFrontOf"} == expected
    pellet = KnowledgeBase(
        hot, ontology=ontology, rule_files=[rules], relations=kinds, cache=default_cache(), reasoner="pellet"
    )
    assert derive(fast) == derive(pellet)
    (bottle,) = [v for v in derive(fast).velocity if v.anchor == "bottle1"]
    assert bottle.rules == ["seen_object", "object_in_front_of_human"]
    angle = abs(math.remainder(math.atan2(0.7 - 1.2, -0.3 - 0.8) - hot.human("col").yaw, math.tau))
    assert f"bottle1 is {angle:.2f} rad from col, below FieldOfView 0.6 rad" in bottle.facts
    # without a rule reading it, the relation is not asserted: it cannot change the cache key
    unread = KnowledgeBase(hot, ontology=ontology, relations=kinds, cache=ReasoningCache(None))
    assert unread.key == KnowledgeBase(hot, ontology=ontology, cache=ReasoningCache(None)).key


def test_user_rules_with_built_ins_over_coordinates_agree_both_ways(tmp_path):
    """A user rule reading coordinates gets them asserted (and keyed); arithmetic and comparisons agree."""
    rules = tmp_path / "high.rules"
    rules.write_text(
        "# Whatever is carried above 0.7 m is treated as hot (a test rule).\n"
        "[carried_high] carries(?a, ?o) ^ hasZ(?o, ?z) ^ swrlb:add(?z2, ?z, 0.5) ^ swrlb:greaterThan(?z2, 1.2)\n"
        "    -> isHot(?o, true)\n"
    )
    handover = example("handover_can")  # can1 is carried at z = 0.78 m, near bob and sue
    kwargs = {"rule_files": [rules]}
    fast = KnowledgeBase(handover, cache=ReasoningCache(None), reasoner="fast", **kwargs)
    assert ("can1", "hasZ", 0.78) in fast.assertions
    assert not [a for a in fast.assertions if a[1] in ("hasX", "hasY", "hasYaw")]  # only what a rule reads
    pellet = KnowledgeBase(handover, cache=default_cache(), reasoner="pellet", **kwargs)
    assert fast.facts == pellet.facts and derive(fast) == derive(pellet)
    (slow,) = derive(fast).velocity
    assert (slow.kind, slow.anchor) == ("ReducedVelocityHot", "can1") and "carried_high" in slow.rules
    lowered = with_object(
        handover, "can1", pose=handover.object("can1").pose.model_copy(update={"xyz": (0.45, 0.85, 0.6)})
    )
    assert derive(KnowledgeBase(lowered, cache=ReasoningCache(None), **kwargs)).velocity == []


def test_a_user_rule_clashing_with_a_packaged_one_fails_alike_both_ways(tmp_path):
    rules = tmp_path / "both.rules"
    rules.write_text(
        "# Contradicts the package rule on purpose.\n"
        "[also_partial] TransportingTask(?t) ^ movesObject(?t, ?o) ^ Can(?o) -> isConstrainedBy(?o, UprightPartial)\n"
    )
    messages = []
    for reasoner, cache in (("fast", ReasoningCache(None)), ("pellet", default_cache())):
        with pytest.raises(HriplanError) as info:
            derive(KnowledgeBase(example("handover_can"), rule_files=[rules], cache=cache, reasoner=reasoner))
        messages.append(str(info.value))
    assert (
        messages[0] == messages[1]
        and "UprightFull and UprightPartial both make constraint 'upright_can1'" in messages[0]
    )


@pytest.mark.parametrize("seed", range(5))
def test_the_closest_approach_matches_dense_sampling(seed):
    """The polyline distance against an independent brute force: 2000 samples per segment."""
    import numpy as np

    from hriplan.ontology.relations import closest_approach

    rng = np.random.default_rng(seed)
    points, target = rng.uniform(-2.0, 2.0, size=(int(rng.integers(1, 6)), 2)), rng.uniform(-2.0, 2.0, size=2)
    points = np.vstack([points, points[-1:]])  # a repeated point: a zero-length segment
    t = np.linspace(0.0, 1.0, 2001)[:, None]
    samples = np.vstack([a + t * (b - a) for a, b in zip(points[:-1], points[1:])])
    brute = min(math.dist(p, target) for p in samples)
    assert closest_approach(points, target) == pytest.approx(brute, abs=2e-3)
    assert closest_approach(points[:1], target) == pytest.approx(math.dist(points[0], target))
