"""contactnet: acyclic quadruped contact planning for Solo12 (the ContactNet paper and beyond)."""

__version__ = "0.1.0"
