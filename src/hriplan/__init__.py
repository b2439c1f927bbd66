"""hriplan: safe human-robot collaboration planning.

Data flows one way: task -> facts -> inferred constraints -> planning problem -> trajectory.
"""

__version__ = "0.1.0"


class HriplanError(ValueError):
    """Bad input or configuration: the message is one line a user can act on."""
