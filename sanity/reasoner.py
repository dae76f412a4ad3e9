"""Reasoners fed the sanity window: the sanity layer builds on rules, so it composes the two, not rules."""

from __future__ import annotations

from functools import lru_cache
from typing import Optional

from discern.rules.catalog import Catalog
from discern.rules.engine import Reasoner
from discern.rules.facts import Params

from .window import WindowConfig, WindowProvider


def default_providers(config: WindowConfig = WindowConfig()) -> list[WindowProvider]:
    return [WindowProvider(config)]


def window_reasoner(catalog: Optional[Catalog] = None, params: Params = Params(), jurisdiction: str = "us",
                    config: WindowConfig = WindowConfig()) -> Reasoner:
    """A Reasoner with the sanity window's facts, which the shipped catalog's sanity rules read."""
    return Reasoner(catalog=catalog, params=params, providers=default_providers(config), jurisdiction=jurisdiction)


def reasoner_for(jurisdiction: str = "us") -> Reasoner:
    """A window Reasoner with the rule pack of `jurisdiction` (us or uk), built once per jurisdiction, however it is
    written.

    Raises ValueError naming the known jurisdictions for any other name.
    """
    return _reasoner_for(str(jurisdiction).strip().lower())


@lru_cache(maxsize=None)
def _reasoner_for(jurisdiction: str) -> Reasoner:
    return window_reasoner(jurisdiction=jurisdiction)
