import json
from pathlib import Path

from discern.rules.schema import MODELS, schema_of, write_schemas

PUBLISHED = Path(__file__).resolve().parents[1] / "rules" / "schema"


def test_published_schemas_match_the_models():
    for name in MODELS:
        published = json.loads((PUBLISHED / f"{name}.schema.json").read_text())
        assert published == schema_of(name), f"run: discern schema --out rules/schema ({name} drifted)"


def test_schema_command_writes_all_three(tmp_path):
    written = write_schemas(tmp_path)
    assert sorted(p.name for p in written) == ["proposal.schema.json", "scene.schema.json", "verdict.schema.json"]
    assert json.loads((tmp_path / "scene.schema.json").read_text())["properties"]["ego"]


def test_every_object_class_says_what_it_is():
    """A class the schema lists without words is a guess for whoever writes an adapter: AV-CSR's `bike` is a
    motorbike, not a bicycle, and the kerb-side rules treat it as one."""
    from discern.rules.scene import OBJECT_CLASSES, ObjectClass

    assert set(OBJECT_CLASSES) == {c.value for c in ObjectClass}
    description = json.loads((PUBLISHED / "scene.schema.json").read_text())["$defs"]["ObjectClass"]["description"]
    for name, words in OBJECT_CLASSES.items():
        assert f"`{name}`: {words}" in description
    assert "`bike`: a motorbike" in description


def test_a_value_reads_as_its_json_name():
    from discern.rules.scene import Action
    from discern.rules.verdict import Decision

    assert f"execute {Action.change_lane_left}" == "execute change_lane_left" and str(Decision.veto) == "veto"
