import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from clingo import Function

from discern.rules.catalog import CatalogError, catalog_dirs, load_catalog, load_driving_rules
from discern.rules.engine import jurisdiction_pack


def test_catalog_has_at_least_35_driving_rules_each_with_english_and_source(reasoner):
    rules = reasoner.catalog.driving_rules()
    assert len(rules) >= 35
    for rule in reasoner.catalog.rules:
        assert rule.id and rule.says.endswith(".") and rule.source


def test_every_predicate_in_a_rule_head_has_an_english_template(reasoner):
    catalog = reasoner.catalog
    missing = {r.signature for r in catalog.compiled} - set(catalog.templates)
    assert missing == set()


def test_every_hazard_a_rule_names_by_a_constant_has_words_of_its_own(reasoner):
    """'there is a hazard: front range obstacle' was its constant's name with the underscores spaced out."""
    catalog = reasoner.catalog
    named = {rule.head[2][0][1].name for rule in catalog.compiled
             if rule.head[:2] == ("f", "hazard") and rule.head[2][0][0] == "s"}
    assert named and named - set(catalog.words) == set()


def write_rules(tmp_path, text):
    (tmp_path / "r.lp").write_text(text)
    return [tmp_path]


def test_rule_without_annotation_is_rejected(tmp_path):
    with pytest.raises(CatalogError, match="r.lp:1: rule has no '%! rule' annotation"):
        load_catalog(write_rules(tmp_path, "a :- b.\n"))


@pytest.mark.parametrize("annotations, problem", [
    ("%! source s\n", r"r\.lp:4: rule x\.b has no '%! says'"),
    ("%! says B.\n", r"r\.lp:4: rule x\.b has no '%! source'"),
    ("", r"r\.lp:4: rule x\.b has no '%! says' and no '%! source'"),
])
def test_a_rule_without_its_english_or_source_is_rejected_not_credited_to_the_rule_before(
        tmp_path, annotations, problem):
    text = "%! rule x.a\n%! says A.\n%! source s\n%! rule x.b\n" + annotations + "a :- b.\n"
    with pytest.raises(CatalogError, match=problem):
        load_catalog(write_rules(tmp_path, text))


def test_a_duplicate_rule_id_is_rejected_naming_both_lines_in_one_file(tmp_path):
    text = "%! rule x.a\n%! says A.\n%! source s\na :- b.\n%! rule x.a\n%! says B.\n%! source s\nc :- d.\n"
    with pytest.raises(CatalogError, match=r"rule id x\.a is used twice \(\S*r\.lp:1, \S*r\.lp:5\)"):
        load_catalog(write_rules(tmp_path, text))


def test_choice_rules_are_rejected_because_they_cannot_be_justified(tmp_path):
    with pytest.raises(CatalogError, match="only normal rules"):
        load_catalog(write_rules(tmp_path, "%! rule x.c\n%! says C.\n%! source s\n{ a } :- b.\n"))


def test_a_rule_through_its_own_negation_is_rejected_as_unstratified(tmp_path):
    text = "%! rule x.loop\n%! says L.\n%! source s\na :- not b.\nb :- not a.\n"
    with pytest.raises(CatalogError, match="must be stratified"):
        load_catalog(write_rules(tmp_path, text))


@pytest.mark.parametrize("statement, problem", [
    ("forbidden(A) :- not hazard(_).", r"r\.lp:9: x\.unsafe: clingo cannot ground it: unsafe variable A: "
                                       r"no positive body atom binds it$"),
    ("p(O, Z) :- q(O), r(O, Y), Y > 0, Y < 3000, not s(W).",  # clingo wrote it `#range(Y,1,2999);[#inc_base]`
     r"r\.lp:9: x\.unsafe: clingo cannot ground it: unsafe variables W, Z: no positive body atom binds them$"),
])
def test_an_unsafe_variable_is_refused_on_loading_naming_the_line_and_rule_not_clingos_rewritten_rule(
        tmp_path, statement, problem):
    text = "%! rule x.safe\n%! says S.\n%! source s\nq(1).\n\n%! rule x.unsafe\n%! says U.\n%! source s\n" + statement
    with pytest.raises(CatalogError, match=problem):
        load_catalog(write_rules(tmp_path, text))


@pytest.mark.parametrize("text, problem", [
    ("%! rule x.fact\n%! says F.\n%! source s\nfoo(X).\n",
     r"r\.lp:4: x\.fact: clingo cannot ground it: unsafe variable X: no positive body atom binds it$"),
    ("%! rule x.count\n%! says C.\n%! source s\nfoo :- #count{X : bar(X)} > 1.\n",
     r"r\.lp:4: x\.count: unsupported literal in a catalog rule: 1 < #count"),
])
def test_a_variable_fact_or_an_aggregate_is_refused_naming_its_file_not_raised(tmp_path, text, problem):
    with pytest.raises(CatalogError, match=problem):
        load_catalog(write_rules(tmp_path, text))


@pytest.mark.parametrize("statement, where", [
    ("a :- b,.\n", r"r\.lp:4:8-9: error: syntax error"),
    ("forbidden(A) :- action(A\n", r"r\.lp:5:1-2: error: syntax error"),  # a bracket left open, not a full stop
])
def test_a_syntax_error_names_the_file_and_line(tmp_path, statement, where):
    with pytest.raises(CatalogError, match=r"r\.lp: cannot parse: .*" + where):
        load_catalog(write_rules(tmp_path, "%! rule x.a\n%! says A.\n%! source s\n" + statement))


@pytest.mark.parametrize("last, where", [
    ("\n\n%! rule x.b\n%! says B.\n%! source s\nr(1).\n", r"\S*r\.lp:9:1-2: error: syntax error, unexpected <IDENTIFIER>"),
    ("  % no full stop, and no statement after it\n", r"\S*r\.lp:5:1-2: error: syntax error, unexpected EOF"),
])
def test_a_missing_full_stop_is_reported_where_its_statement_ends_not_where_clingo_stumbles(tmp_path, last, where):
    # clingo finds it at the next statement's first token, maybe a block further on
    text = "%! rule x.a\n%! says A.\n%! source s\np(O, Y) :- q(O, Y), Y > 0, Y < 3000" + last
    with pytest.raises(CatalogError, match=r"r\.lp:4: x\.a: cannot parse: the statement ends on this line without "
                                           r"a full stop \(clingo: " + where):
        load_catalog(write_rules(tmp_path, text))


@pytest.mark.parametrize("template, problem", [
    ('"@(D:metres) ahead"', r"r\.lp:1: unknown format 'metres' in @\(D:metres\)"),
    ('"@(X) ahead"', r"r\.lp:1: @\(X\) names no parameter of gap"),
])
def test_a_template_placeholder_must_name_a_parameter_and_a_known_format(tmp_path, template, problem):
    with pytest.raises(CatalogError, match=problem):
        load_catalog(write_rules(tmp_path, f"%! pred gap(D) :: {template}\n"))


@pytest.mark.parametrize("text, problem", [
    ('%! reads gap(D) :: "a gap of @(D:m)"\n', r"r\.lp:1: 'reads' before any '%! rule'"),
    ('%! rule x.a\n%! says A.\n%! source s\n%! reads gap(D) :: "a gap of @(D:m)"\nlane(1) :- b.\n',
     r"r\.lp:4: 'reads' gives words for gap/1, which rule x\.a does not derive"),
    ('%! rule x.a\n%! says A.\n%! source s\n%! reads gap(D) :: "a gap of @(E:m)"\ngap(1) :- b.\n',
     r"r\.lp:4: @\(E:m\) names no parameter of gap"),
])
def test_a_rules_own_words_must_sit_in_its_block_and_fit_what_it_derives(tmp_path, text, problem):
    with pytest.raises(CatalogError, match=problem):
        load_catalog(write_rules(tmp_path, text))


def test_rules_deriving_an_atom_skip_heads_about_another_constant_and_keep_catalog_order(reasoner):
    catalog = reasoner.catalog
    every = catalog.by_head[("applicable", 1)]
    brake = catalog.rules_deriving("applicable", 1, Function("brake"))
    heads = {str(rule.head[2][0][1]) for rule in every if rule.head[2][0][0] == "s"}
    assert {"brake", "accelerate"} <= heads
    assert brake == [r for r in every if r.head[2][0][0] != "s" or r.head[2][0][1] == Function("brake")]
    assert brake and len(brake) < len(every)
    assert catalog.rules_deriving("applicable", 1, None) == every


@pytest.mark.parametrize("line, problem", [
    ("%! rules x.b", r"r\.lp:5: not an annotation: '%! rules x\.b'"),
    ("%! rule", r"r\.lp:5: '%! rule' without its id"),
    ("%! rule   ", r"r\.lp:5: '%! rule' without its id"),
    ("%! says", r"r\.lp:5: '%! says' without its value"),
    ("%! source ", r"r\.lp:5: '%! source' without its value"),
    ("%! sayz B.", r"r\.lp:5: not an annotation: '%! sayz B\.'"),
    ("%!", r"r\.lp:5: not an annotation: '%!'"),
    ("%! rule x.b c", r"r\.lp:5: rule id 'x\.b c' holds white space"),
])
def test_a_broken_annotation_line_is_an_error_naming_its_file_and_line_not_credited_to_the_rule_before(
        tmp_path, line, problem):
    # a misspelt `%! rule` line used to be passed over: the block's says and source then overwrote x.a's
    text = "%! rule x.a\n%! says A.\n%! source s\na :- b.\n" + line + "\n%! says B.\n%! source t\nc :- d.\n"
    with pytest.raises(CatalogError, match=problem):
        load_catalog(write_rules(tmp_path, text))


def test_a_new_rule_that_closes_a_cycle_through_forbidden_and_permitted_is_the_one_named(tmp_path):
    """Once the first shipped rule with a head in the cycle was named, for the edge the new rule added to that head."""
    closing = "%! rule cll.x\n%! says X.\n%! source review\nforbidden(change_lane_left) :- not permitted(cruise).\n"
    edited = edited_catalog(tmp_path, zz_new=closing)
    with pytest.raises(CatalogError) as refused:
        load_driving_rules([str(edited)], [jurisdiction_pack("us")])
    assert re.search(r"by cll\.x at \S*zz_new\.lp:4\b|zz_new\.lp:4: cll\.x:", str(refused.value)), str(refused.value)
    assert "brake." not in str(refused.value)  # a shipped rule whose head the new rule shares closes no cycle


@pytest.mark.parametrize("pack", ["us", "uk"])
def test_every_shipped_catalog_loads_each_annotated_rule_under_its_own_id(pack):
    # each pack with the catalogs, as they are loaded: the two packs together set the lane changes' ranks twice
    root = Path(__file__).resolve().parents[1]
    files = [*(root / "rules" / "catalog").glob("*.lp"), *(root / "sanity" / "catalog").glob("*.lp"),
             root / "rules" / "jurisdictions" / f"{pack}.lp"]
    annotated = sorted(line.split()[2] for path in files
                       for line in path.read_text(encoding="utf-8").splitlines() if line.startswith("%! rule "))
    catalog = load_catalog([root / "rules" / "catalog", root / "sanity" / "catalog"], files[-1:])
    assert sorted(rule.id for rule in catalog.rules) == annotated


@pytest.mark.parametrize("statement", ["{ c }.", "a | b.", ":- ."])
def test_a_bodiless_choice_disjunction_or_constraint_is_rejected_with_its_line(tmp_path, statement):
    with pytest.raises(CatalogError, match=r"r\.lp:4: only normal rules and facts are supported"):
        load_catalog(write_rules(tmp_path, "%! rule x.c\n%! says C.\n%! source s\n" + statement + "\n"))


def test_a_rules_directory_without_the_decision_rules_is_refused(tmp_path):
    edited = tmp_path / "rules"
    shutil.copytree(catalog_dirs()[0], edited)
    (edited / "90_decision.lp").unlink()
    with pytest.raises(CatalogError, match=r"define no action/1, permitted/1, recommended/1: the decision rules"):
        load_driving_rules([edited])


@pytest.mark.parametrize("statement", ["-fast(1).", "-slow(X) :- speed(X).", "slowish(X) :- speed(X), not -fast(X)."])
def test_classical_negation_is_rejected_with_its_line(tmp_path, statement):
    # the prover and the slicers read each atom's predicate from its name: `-fast(1)` crashed them
    with pytest.raises(CatalogError, match=r"r\.lp:4: classical negation \('-p'\) is not supported"):
        load_catalog(write_rules(tmp_path, "%! rule x.c\n%! says C.\n%! source s\n" + statement + "\n"))


@pytest.mark.parametrize("block, problem", [
    ("%! says B.\n%! source t\n",
     r"r\.lp:5: a second '%! says' for rule x\.a \(line 2\): the rule block at \S*r\.lp:5 has no `%! rule` line"),
    ("%! source t\n",
     r"r\.lp:5: a second '%! source' for rule x\.a \(line 3\): the rule block at \S*r\.lp:5 has no `%! rule` line"),
])
def test_a_block_without_its_rule_line_is_refused_not_credited_to_the_rule_before(tmp_path, block, problem):
    # its statement used to take x.a's id and its says overwrote x.a's: a veto credited to the wrong rule
    text = "%! rule x.a\n%! says A.\n%! source s\na :- b.\n" + block + "forbidden(brake) :- c.\n"
    with pytest.raises(CatalogError, match=problem):
        load_catalog(write_rules(tmp_path, text))


def test_a_source_after_the_blocks_statements_starts_a_block_without_its_rule_line(tmp_path):
    text = "%! rule x.a\n%! says A.\na :- b.\n\n%! source t\nforbidden(brake) :- c.\n"
    with pytest.raises(CatalogError, match=r"r\.lp:5: '%! source' after rule x\.a's statement at line 3: "
                                           r"the rule block at \S*r\.lp:5 has no `%! rule` line"):
        load_catalog(write_rules(tmp_path, text))


def edited_catalog(tmp_path, **files):
    """A copy of the shipped driving rules with these files added (name without .lp -> text)."""
    edited = tmp_path / "rules"
    shutil.copytree(catalog_dirs()[0], edited)
    for name, text in files.items():
        (edited / f"{name}.lp").write_text(text)
    return edited


def test_a_second_template_for_a_shipped_predicate_is_refused_naming_both_places(tmp_path):
    # it used to replace the shipped wording of in_ego_lane in every proof
    edited = edited_catalog(tmp_path, zz_bus='%! pred in_ego_lane(O) :: "@(O:obj) is in a bus lane"\n')
    with pytest.raises(CatalogError, match=r"zz_bus\.lp:1: a second '%! pred' for in_ego_lane/1: "
                                           r"it has words at \S*10_geometry\.lp:\d+ already"):
        load_driving_rules([edited], [jurisdiction_pack("us")])


def test_a_second_wording_for_a_constant_is_refused_naming_both_places(tmp_path):
    text = '%! term current :: "same-direction"\n\n%! term current :: "this way"\n'
    with pytest.raises(CatalogError, match=r"r\.lp:3: a second '%! term' for current: it has words at \S*r\.lp:1 already"):
        load_catalog(write_rules(tmp_path, text))


PREFERENCE = "%! rule dec.swerve_first\n%! says Changing lanes to the left comes first.\n%! source review\n"


@pytest.mark.parametrize("pack", ["us", "uk"])
def test_an_action_ranked_again_beside_its_packs_rank_is_refused_naming_both_rules(tmp_path, pack):
    # it loaded, and ranked change_lane_left below itself: an override with brake that nothing recommended
    edited = edited_catalog(tmp_path, zz_prefs=PREFERENCE + "rank(change_lane_left, 0).\n")
    rank = {"us": 4, "uk": 5}[pack]
    with pytest.raises(CatalogError, match=rf"{pack}\.lp:\d+: jur\.{pack}\.lane_preference: change_lane_left is ranked "
                                           rf"twice: {rank} here, 0 by dec\.swerve_first at \S*zz_prefs\.lp:1 \(rank/2"):
        load_driving_rules([edited], [jurisdiction_pack(pack)])


def test_two_actions_of_one_rank_are_refused_naming_both_rules(tmp_path):
    edited = edited_catalog(tmp_path, zz_prefs=PREFERENCE + "rank(change_lane_left, 2).\n")
    with pytest.raises(CatalogError, match=r"zz_prefs\.lp:1: dec\.swerve_first: rank 2 is given twice: to change_lane_left "
                                           r"here, to turn_right by def\.rank at \S*90_decision\.lp:\d+ \(rank/2"):
        load_driving_rules([edited], [jurisdiction_pack("us")])


TRUCKS = """%! pred large_vehicle(C) :: "a @(C) is a large vehicle"
%! pred truck_too_close(O, D) :: "@(O:obj), a large vehicle, is only @(D:m) ahead in the ego's lane"
%! term truck_ahead(O) :: "@(O:obj) is no reason to hold back"

%! rule acc.truck_ahead
%! says The ego does not accelerate while a large vehicle ahead in its lane is nearer than 30 m.
%! source review
forbidden(accelerate) :- truck_too_close(O, _), not ab(truck_ahead(O)).

%! rule def.truck_too_close
%! says A large vehicle ahead in the ego's lane nearer than 30 m is too close.
%! source review
truck_too_close(O, Y) :- in_ego_lane(O), object(O, C), large_vehicle(C), obj_pos(O, _, Y), Y > 0, Y < 3000.

%! rule ent.large_vehicle
%! says Trucks and buses are large vehicles.
%! source review
large_vehicle(truck). large_vehicle(bus).
"""
BUS_EXCEPTION = """
%! rule acc.bus_exception
%! says A bus ahead is no reason to hold back.
%! source review
ab(truck_ahead(O)) :- in_ego_lane(O), object(O, bus).
"""


def test_an_exception_hook_about_an_object_loads_and_decides_as_plain_clingo_does(tmp_path):
    # per predicate, ab -> in_ego_lane -> not not_on_road -> ... -> not ab(beyond_reach(..)) was a cycle; the atoms
    # ab(truck_ahead(..)) and ab(beyond_reach(..)) are not one another
    import clingo

    from discern.rules.scene import Action
    from discern.sanity import window_reasoner

    from .scenes import obj, scene

    edited = edited_catalog(tmp_path, zz_trucks=TRUCKS + BUS_EXCEPTION)
    reasoner = window_reasoner(catalog=load_driving_rules([edited], [jurisdiction_pack("us")]))
    files = [*sorted(edited.glob("*.lp")), *sorted(catalog_dirs()[1].glob("*.lp")), jurisdiction_pack("us")]
    for cls, forbidden in (("truck", True), ("bus", False)):
        frame = scene(speed=10.0, lane=2, lanes=2, limit=20.0, objects=(obj(cls, 0.0, 25.0, lane=2, vy=10.0),))
        verdict = reasoner.decide(frame, "accelerate")
        assert (verdict.decision.value, verdict.vetoed_by) == (("override", ["acc.truck_ahead"]) if forbidden
                                                               else ("approve", []))
        control = clingo.Control(["0", "--warn=none"])
        for path in files:
            control.load(str(path))
        control.add("base", [], reasoner.frame_facts(frame, Action.accelerate, []) + reasoner.params.facts())
        control.ground([("base", [])])
        models = []
        control.solve(on_model=lambda m: models.append(m.contains(Function("forbidden", [Function("accelerate")]))))
        assert models == [forbidden]


def test_a_cycle_through_negation_is_named_by_the_rules_that_close_it_the_same_every_run(tmp_path):
    cycle = "\n%! rule def.cycle\n%! says C.\n%! source review\nlarge_vehicle(C) :- object(_, C), not truck_too_close(_, _).\n"
    edited = edited_catalog(tmp_path, zz_trucks=TRUCKS + cycle)
    load = ("from discern.rules.catalog import load_driving_rules\nfrom discern.rules.engine import jurisdiction_pack\n"
            f"try:\n    load_driving_rules([{str(edited)!r}], [jurisdiction_pack('us')])\n"
            "except ValueError as exc:\n    print(exc)\n")
    said = {subprocess.run([sys.executable, "-c", load], capture_output=True, text=True, check=True,
                           env={**os.environ, "PYTHONHASHSEED": seed}).stdout for seed in ("1", "2")}
    assert len(said) == 1
    assert re.fullmatch(r"\S*zz_trucks\.lp:23: def\.cycle: large_vehicle depends on itself through 'not truck_too_close'; "
                        r"truck_too_close rests on large_vehicle by def\.truck_too_close at \S*zz_trucks\.lp:13: "
                        r"the catalog must be stratified\n", said.pop())


@pytest.mark.parametrize("pack", ["us", "uk"])
def test_the_shipped_catalog_with_either_pack_loads_without_a_warning(pack):
    # the UK pack gives no school_bus_law: a setting the catalog declares with a template, not a misspelling
    assert load_catalog(extra_files=[jurisdiction_pack(pack)]).warnings == []


@pytest.mark.parametrize("edit, warning", [
    (("large_vehicle(C), obj_pos", "large_vehicles(C), obj_pos"),
     r"zz_trucks\.lp:13: def\.truck_too_close: nothing gives large_vehicles/1: no catalog fact, rule or frame fact, "
     r"and no '%! pred' declares it \(did you mean large_vehicle/1\?\)"),
    (("not ab(truck_ahead(O))", "not truck_exmept(O)"),
     r"zz_trucks\.lp:8: acc\.truck_ahead: nothing gives truck_exmept/1: .* \(did you mean truck_exempt/1\?\)"),
    (("Y < 3000", "param(truck_dist, T), Y < T"),
     r"zz_trucks\.lp:13: def\.truck_too_close: param\(truck_dist, _\) names no setting \(did you mean turn_dist\?\)"),
    (("forbidden(accelerate) :-", "forbiden(accelerate) :-"),
     r"zz_trucks\.lp:8: acc\.truck_ahead: nothing reads forbiden/1: no rule's body, nor the verdict "
     r"\(did you mean forbidden/1\?\)"),
])
def test_a_misspelt_predicate_or_setting_loads_with_a_warning_naming_its_line_and_rule(tmp_path, edit, warning):
    # each loaded silently, and its rule never fired (or was never blocked)
    declared = '%! pred truck_exempt(O) :: "@(O:obj) pulls away"\n%! pred forbiden(A) :: "@(A) is forbidden"\n'
    edited = edited_catalog(tmp_path, zz_trucks=TRUCKS.replace(*edit), zz_words=declared)
    warnings = load_driving_rules([edited], [jurisdiction_pack("us")]).warnings
    assert [w for w in warnings if re.search(warning, w)] != [], warnings
    assert all("zz_" in w for w in warnings), warnings  # the shipped rules' own are never warned of


@pytest.mark.parametrize("edit, problem", [
    (('%! pred truck_too_close(O, D) :: "@(O:obj), a large vehicle, is only @(D:m) ahead in the ego\'s lane"\n', ""),
     r"zz_trucks\.lp:12: def\.truck_too_close: truck_too_close/2 has no '%! pred' template: its atoms would read as "
     r"raw terms, numbers in centimetres$"),
    (("truck_too_close(O, D) :: \"@(O:obj), a large vehicle, is only @(D:m) ahead",  # an arity no predicate has
      "truck_too_close(O) :: \"@(O:obj), a large vehicle, is close ahead"),
     r"zz_trucks\.lp:13: def\.truck_too_close: truck_too_close/2 has no '%! pred' template: .* "
     r"\(the one at \S*zz_trucks\.lp:2 is for truck_too_close/1\)$"),
    (("forbidden(accelerate) :-", "forbiden(accelerate) :-"),
     r"zz_trucks\.lp:8: acc\.truck_ahead: forbiden/1 has no '%! pred' template: .* \(did you mean forbidden/1\?\)$"),
    (("large_vehicle(truck).", "large_vehicle(truck).\nhazard(truck_close(O, Y)) :- truck_too_close(O, Y), Y < 2700."),
     r"zz_trucks\.lp:19: ent\.large_vehicle: the hazard truck_close/2 has no '%! term' template"),
])
def test_a_derived_predicate_or_hazard_without_words_is_refused_naming_its_line_and_rule(tmp_path, edit, problem):
    # each read as raw atoms in every proof: "truck_too_close(7, 2500)", "there is a hazard: truck close (7, 2500)"
    edited = edited_catalog(tmp_path, zz_trucks=TRUCKS.replace(*edit))
    with pytest.raises(CatalogError, match=problem):
        load_driving_rules([edited], [jurisdiction_pack("us")])


def test_words_missing_where_a_proof_would_show_them_or_given_for_nothing_load_with_a_warning(tmp_path):
    unused = '%! pred truck_exempt(O) :: "@(O:obj) pulls away"\n'
    edited = edited_catalog(tmp_path, zz_trucks=unused + TRUCKS.replace("%! term truck_ahead(O)", "% no term")
                            + BUS_EXCEPTION + "\n%! rule ent.bus\n%! says B.\n%! source s\nbus_class(bus).\n")
    warnings = load_driving_rules([edited], [jurisdiction_pack("us")]).warnings
    assert [re.sub(r"^\S*/", "", w) for w in warnings] == [
        "zz_trucks.lp:24: acc.bus_exception: the term truck_ahead/1 in its head has no '%! term' template",
        "zz_trucks.lp:29: ent.bus: bus_class/1 has no '%! pred' template",
        "zz_trucks.lp:1: the template for truck_exempt/1 words no predicate or term that the catalog uses",
    ]
