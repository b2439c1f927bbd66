"""Import Kautham problem files (the seed framework's XML) as hriplan planning problems."""

from hriplan.formats.kautham.problem import import_kautham

__all__ = ["import_kautham"]
