"""The frame rules clingo grounds are the catalog's, settled against what no frame changes (rules/specialize.py).

That the answer sets stay those of the catalog as written is test_engine.py's long random run, in both
jurisdictions; here, what the specialised rules look like."""

import re
import subprocess
import sys
from pathlib import Path

import clingo
import pytest
from clingo import ast

from discern.rules.catalog import static_model
from discern.rules.engine import Reasoner
from discern.rules.fact_text import fact_names
from discern.rules.facts import Params
from discern.rules.specialize import Specializer
from discern.sanity import window_reasoner
from tests.scenes import scene


def grounded_form(reasoner, rule_text):
    """The statement clingo gets for the catalog rule written as `rule_text` (None: left out)."""
    matches = [rule for rule in reasoner.catalog.compiled if str(rule.statement) == rule_text]
    assert len(matches) == 1, f"no single catalog rule reads {rule_text!r}"
    special = reasoner.slicer.specializer.statement(matches[0].statement)
    return None if special is None else str(special)


@pytest.fixture(scope="module")
def us():
    return window_reasoner(jurisdiction="us")


@pytest.fixture(scope="module")
def uk():
    return window_reasoner(jurisdiction="uk")


def test_parameters_are_put_into_the_rules_that_read_them(us):
    special = grounded_form(us, "braking_distance(C,D) :- needs_braking(C); C > 0; param(reaction_ms,R); "
                                "param(decel,A); D = (((C*R)/1000)+((C*C)/(2*A))).")
    assert "param(" not in special
    assert special == "braking_distance(C,D) :- needs_braking(C); C > 0; D = (((C*1000)/1000)+((C*C)/(2*600)))."


def test_a_rule_for_the_other_side_of_the_road_is_left_out(us, uk):
    # grounded as the record of which rule derived the atom (catalog.TRACED), the rule's index last
    written = re.compile(r"(__by_applicable\(change_lane_right,\d+\)) :- slower_lead\(Any0\); passing_side\(right\)\.")
    [(rule, head)] = [(str(r.statement), found.group(1)) for r in us.catalog.compiled
                      for found in [written.fullmatch(str(r.statement))] if found]
    assert grounded_form(us, rule) is None
    assert grounded_form(uk, rule) == f"{head} :- slower_lead(Any0)."


def test_a_rule_whose_parameters_contradict_it_is_left_out(us):
    # the comfortable deceleration is below the firm one, so this body can never hold
    rule = ("comfort_braking_distance(C,D) :- needs_braking(C); C > 0; comfortable_decel(A); param(decel,F); A > F; "
            "braking_distance(C,D).")
    assert grounded_form(us, rule) is None


def test_other_parameters_change_what_the_rules_read():
    fast = window_reasoner(params=Params(reaction_s=1.5))
    special = grounded_form(fast, "braking_distance(C,D) :- needs_braking(C); C > 0; param(reaction_ms,R); "
                                  "param(decel,A); D = (((C*R)/1000)+((C*C)/(2*A))).")
    assert "C*1500" in special


def test_a_variable_is_not_given_two_constant_bounds_which_clingo_would_enumerate(us):
    # `Y >= 0; Y < 1500` makes clingo walk every value from 0 to 1499 (measured: 60 us, 4 ms for 100000)
    special = grounded_form(us, "near_turn_path(O) :- obj_pos(O,X,Y); Y >= 0; Y < W; |X| < W; param(crossing_dist,W).")
    assert special == "near_turn_path(O) :- obj_pos(O,X,Y); Y >= 0; Y < W; |X| < W; param(crossing_dist,W)."


def specialised(rule_text, constant="param(w,1500).", static=frozenset({"param"})):
    statements = []
    ast.parse_string(rule_text, statements.append)
    return str(Specializer(static_model([], constant), static).statement(statements[-1]))


def test_a_bound_reached_through_an_assignment_stays_the_static_atoms():
    # `H = 1500; Y < H` is folded by clingo into a second constant bound of Y
    rule = "p(O) :- q(O,Y); Y >= 0; H = W; Y < H; param(w,W)."
    assert specialised(rule) == "p(O) :- q(O,Y); Y >= 0; H = W; Y < H; param(w,W)."


def test_a_single_constant_bound_is_put_in():
    assert specialised("p(O) :- q(O,Y); Y < W; param(w,W).") == "p(O) :- q(O,Y); Y < 1500."


def answer_sets(rules, static_facts, frame_facts):
    """The answer set of the rules as written and of the rules specialised to `static_facts`, with `frame_facts`."""
    statements = []
    ast.parse_string(rules, statements.append)
    written = [s for s in statements if s.ast_type == ast.ASTType.Rule]
    special = Specializer(static_model([], static_facts), fact_names(static_facts)).program(written)
    found = []
    for program in (written, special):
        control = clingo.Control(["--warn=none"])
        with ast.ProgramBuilder(control) as builder:
            for statement in program:
                builder.add(statement)
        control.add("base", [], static_facts + frame_facts)
        control.ground([("base", [])])
        found.append({str(atom.symbol) for atom in control.symbolic_atoms if atom.is_fact})
    return found


def test_a_negated_static_literal_with_undefined_arithmetic_drops_the_rule_instance_as_clingo_does():
    # no s atom is like s(b,_), yet clingo drops the instance whose V/0 is undefined rather than hold `not`
    written, special = answer_sets("p(V) :- q(V); not s(b,V/0).", "s(a,1).", "q(1).")
    assert "p(1)" not in written
    assert special == written


def test_a_comparison_clingo_holds_undefined_does_not_hold():
    # clingo.parse_term makes 0**-1 0; to the grounder it is undefined, and the comparison does not hold
    written, special = answer_sets("p(V) :- q(V); s(N); (N-1)**-1 = 0.", "s(1).", "q(1).")
    assert "p(1)" not in written
    assert special == written


def test_a_remainder_by_zero_is_left_to_clingo_which_holds_it_undefined():
    # clingo.parse_term("1\0") ends the process (SIGFPE): specialising is run apart, so that the test can fail
    code = ("from tests.test_rules_specialized import answer_sets\n"
            "found = answer_sets('p(V) :- q(V); s(N); N\\\\(N-1) = 0.', 's(1).', 'q(1).')\n"
            "print([sorted(atoms) for atoms in found])")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=Path(__file__).parent.parent)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == str([["q(1)", "s(1)"]] * 2)


def test_a_function_pattern_does_not_match_the_negated_function():
    written, special = answer_sets("p(X) :- q(_); s(f(X)). r(X) :- q(_); s((X,2)).", "s(-f(1)). s(-(1,2)).", "q(1).")
    assert not {"p(1)", "r(1)"} & written
    assert special == written


def test_a_chain_of_comparisons_is_not_given_two_constant_bounds():
    # `0 <= Y < 1500` is two bounds to clingo, which walks the range
    rule = "p(O) :- q(O,Y); 0 <= Y < W; param(w,W)."
    assert specialised(rule) == rule


def test_bounds_that_an_equality_carries_over_to_a_variable_stay_the_static_atoms():
    # clingo moves `D >= 0` onto Y through `D = Y+1`: with `Y < 1500` it walks the range
    rule = "p(O) :- q(O,Y); D = (Y+1); D >= 0; Y < W; param(w,W)."
    assert specialised(rule) == rule


class _WetRoad:
    """A fact provider that gives a parameter of its own: the rules already have the reasoner's put in."""

    predicates = frozenset({("param", 2)})
    params = frozenset()

    def facts(self, scene, history):
        return "param(decel,300)."


def test_a_frame_fact_giving_a_parameter_is_refused_alone_as_in_a_batch():
    reasoner = Reasoner(providers=[_WetRoad()])
    frame = (scene(speed=10), "cruise", ())
    with pytest.raises(ValueError, match="frame fact param .* cannot be given per frame"):
        reasoner.solve_many([frame, frame])
    with pytest.raises(ValueError, match="frame fact param .* cannot be given per frame"):
        reasoner.solve(*frame)
