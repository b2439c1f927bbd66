"""Inference rules: from situations to constraint sets, with provenance."""
