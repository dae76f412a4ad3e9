"""Every sanity and jurisdiction rule: its worked example fires it, its near miss does not."""

from __future__ import annotations

from pathlib import Path

import pytest

from discern.sanity import examples
from discern.sanity.examples import EXAMPLES, fired
from discern.sanity.jurisdiction import reasoner_for

BY_RULE = {e.rule: e for e in EXAMPLES}
DOC = Path(__file__).resolve().parents[1] / "docs" / "sanity.md"


def _layer_rules(jurisdiction: str) -> set[str]:
    return {r.id for r in reasoner_for(jurisdiction).catalog.driving_rules() if r.id.startswith(("san.", "jur."))}


def test_every_sanity_and_jurisdiction_rule_has_a_worked_example():
    assert _layer_rules("us") | _layer_rules("uk") == set(BY_RULE)


@pytest.mark.parametrize("rule", sorted(BY_RULE))
def test_rule_fires_in_its_example(rule):
    example = BY_RULE[rule]
    reasoner, _ = example.reasoners()
    assert rule in fired(reasoner, example.frames, example.proposed)


@pytest.mark.parametrize("rule", sorted(BY_RULE))
def test_rule_does_not_fire_in_its_near_miss(rule):
    example = BY_RULE[rule]
    _, reasoner = example.reasoners()
    assert rule not in fired(reasoner, example.blocked, example.proposed)


def test_uk_pack_rules_have_english_sources_and_templates():
    catalog = reasoner_for("uk").catalog
    assert all(r.says.endswith(".") and r.source for r in catalog.rules)
    assert {r.signature for r in catalog.compiled} - set(catalog.templates) == set()


def test_docs_show_the_engines_own_output_for_every_example():
    text = DOC.read_text(encoding="utf-8")
    block = text[text.index(examples.BEGIN) + len(examples.BEGIN): text.index(examples.END)]
    assert block.strip() == examples.markdown(EXAMPLES).strip(), (
        "docs/sanity.md is out of date: run `python -m discern.sanity.examples docs/sanity.md`")
