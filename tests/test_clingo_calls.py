"""What clingo's C functions give through clingo_calls is what its public Python API gives."""

import clingo
import pytest

from discern.rules import clingo_calls
from discern.rules.clingo_calls import AtomReader, add_facts

RULES = "near(O) :- obj_pos(O,_,Y), Y < 1000. class_of(O,C) :- object(O,C). said(\"a \\\"long\\\" name\",O) :- near(O)."
FACTS = "(object(1,car),object(2,pedestrian),obj_pos(1,0,500),obj_pos(2,-150,2500),ego_speed(1340),in_city)"


def grounded_atoms() -> set[str]:
    control = clingo.Control(["--warn=none"])
    control.add("base", [], RULES)
    add_facts(control, clingo.parse_term(FACTS).arguments)
    control.ground([("base", [])])
    return {str(a.symbol) for a in control.symbolic_atoms if a.is_fact}


def test_facts_through_the_c_functions_ground_the_same_atoms_as_through_the_public_backend(monkeypatch):
    assert clingo_calls._C_CALLS  # this clingo has them: the fast path is the one measured
    through_c = grounded_atoms()
    monkeypatch.setattr(clingo_calls, "_C_CALLS", False)
    assert grounded_atoms() == through_c
    assert {"near(1)", "class_of(2,pedestrian)", "in_city", "obj_pos(2,-150,2500)"} <= through_c
    assert "near(2)" not in through_c


@pytest.mark.parametrize("fast", [True, False])
def test_a_symbol_that_is_no_atom_is_refused_with_clingos_message_on_either_path(monkeypatch, fast):
    monkeypatch.setattr(clingo_calls, "_C_CALLS", fast and clingo_calls._C_CALLS)
    with pytest.raises(RuntimeError, match="function expected"):
        add_facts(clingo.Control(), [clingo.Function("ok"), clingo.Number(5)])


def read_back(monkeypatch, fast: bool) -> dict:
    monkeypatch.setattr(clingo_calls, "_C_CALLS", fast)
    control = clingo.Control(["--warn=none"])
    control.add("base", [], RULES + "far(" + "x" * 400 + ").")  # a text longer than the reader's first buffer
    add_facts(control, clingo.parse_term(FACTS).arguments)
    control.ground([("base", [])])
    reader = AtomReader(control)
    atoms = [a.symbol for a in control.symbolic_atoms]
    return {
        "holds": [reader.holds(clingo.parse_term(t)) for t in ("near(1)", "near(2)", "object(2,pedestrian)", "in_city")],
        "of": [reader.of(name, arity) for name, arity in (("class_of", 2), ("near", 1), ("absent", 3))],
        "any_of": [reader.any_of(name, arity) for name, arity in (("near", 1), ("near", 2), ("said", 2))],
        "text": [reader.text(a) for a in atoms],
        "shape": [reader.shape(s) for a in atoms for s in (a, *a.arguments)],
    }


def test_the_reader_gives_the_atoms_texts_and_shapes_of_the_public_api(monkeypatch):
    assert clingo_calls._C_CALLS
    through_c = read_back(monkeypatch, True)
    assert read_back(monkeypatch, False) == through_c
    assert through_c["holds"] == [True, False, True, True]
    assert [sorted(map(str, atoms)) for atoms in through_c["of"]] == [
        ["class_of(1,car)", "class_of(2,pedestrian)"], ["near(1)"], []]
    assert through_c["any_of"] == [True, False, True]
    assert '"a \\"long\\" name"' in " ".join(through_c["text"]) and "far(" + "x" * 400 + ")" in through_c["text"]
    assert (False, None, ()) in through_c["shape"] and (True, "in_city", ()) in through_c["shape"]
