"""ISO/TS 15066 speed and separation: formulas, the policy read from the ontology, the planner's
separation zones, the approach monitor and the person distances it measures."""
