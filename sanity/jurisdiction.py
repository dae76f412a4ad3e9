"""Reasoners per jurisdiction, for the CLI's --jurisdiction and the scenario runner."""

from __future__ import annotations

from functools import lru_cache

from discern.rules.engine import JURISDICTIONS, Reasoner


@lru_cache(maxsize=None)
def reasoner_for(jurisdiction: str = "us") -> Reasoner:
    """A Reasoner with the rule pack of `jurisdiction` (us or uk); built once per name.

    Raises ValueError naming the known jurisdictions for any other name.
    """
    return Reasoner(jurisdiction=jurisdiction.strip().lower())


__all__ = ["JURISDICTIONS", "reasoner_for"]
