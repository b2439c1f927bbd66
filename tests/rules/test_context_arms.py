"""A context reads each arm from the facts once and gives that arm again, whichever arm was asked before."""

from hriplan.ontology.knowledge_base import KnowledgeBase
from hriplan.ontology.situation import EXAMPLES_DIR, load_situation
from hriplan.robots.model import arms_of
from hriplan.rules.instantiate import Context


def test_each_arm_is_the_one_a_fresh_context_reads_in_any_order():
    kb = KnowledgeBase(load_situation(EXAMPLES_DIR / "handover_can.json"))
    individuals = [f"{kb.situation.robot}_{arm}" for arm in arms_of(kb.situation.robot)]
    assert len(individuals) == 2  # MADAR's two arms
    fresh = {i: Context(kb.situation, kb.facts).arm(i) for i in individuals}
    for order in (individuals, individuals[::-1]):
        ctx = Context(kb.situation, kb.facts)
        for individual in order + order:
            assert ctx.arm(individual) == fresh[individual]
    assert fresh[individuals[0]] != fresh[individuals[1]]
