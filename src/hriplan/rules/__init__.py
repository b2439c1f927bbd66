"""Inference rules: from situations to planner constraints, with provenance.

- `*.rules`: the SWRL rules, one named rule with its rationale per entry (format: `ruleset`).
- `matching`: a rule body matched against facts (the in-process reasoner and provenance).
- `infer.derive` / `infer.infer_constraints`: the planner constraints (and velocity scale) a
  situation requires, each with the rules and facts behind it; `explain.explain` in words.
"""
