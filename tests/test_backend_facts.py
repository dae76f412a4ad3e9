"""Facts handed to clingo through its C functions are the facts the public backend gives."""

import clingo
import pytest

from discern.rules import backend_facts
from discern.rules.backend_facts import add_facts

RULES = "near(O) :- obj_pos(O,_,Y), Y < 1000. class_of(O,C) :- object(O,C)."
FACTS = "(object(1,car),object(2,pedestrian),obj_pos(1,0,500),obj_pos(2,-150,2500),ego_speed(1340),in_city)"


def grounded_atoms() -> set[str]:
    control = clingo.Control(["--warn=none"])
    control.add("base", [], RULES)
    add_facts(control, clingo.parse_term(FACTS).arguments)
    control.ground([("base", [])])
    return {str(a.symbol) for a in control.symbolic_atoms if a.is_fact}


def test_facts_through_the_c_functions_ground_the_same_atoms_as_through_the_public_backend(monkeypatch):
    assert backend_facts._C_CALLS  # this clingo has them: the fast path is the one measured
    through_c = grounded_atoms()
    monkeypatch.setattr(backend_facts, "_C_CALLS", False)
    assert grounded_atoms() == through_c
    assert {"near(1)", "class_of(2,pedestrian)", "in_city", "obj_pos(2,-150,2500)"} <= through_c
    assert "near(2)" not in through_c


@pytest.mark.parametrize("fast", [True, False])
def test_a_symbol_that_is_no_atom_is_refused_with_clingos_message_on_either_path(monkeypatch, fast):
    monkeypatch.setattr(backend_facts, "_C_CALLS", fast and backend_facts._C_CALLS)
    with pytest.raises(RuntimeError, match="function expected"):
        add_facts(clingo.Control(), [clingo.Function("ok"), clingo.Number(5)])
