"""One worked example per sanity and jurisdiction rule: where it fires, and a near miss where it does not.

Test data and a documentation generator, not part of the installed package: the tests check every example
against the engine, and docs/sanity.md shows each one with the engine's own justification, regenerated from the
repository root with

    python -m tests.worked_examples docs/sanity.md
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

from discern.rules.engine import Reasoner
from discern.rules.justify import Prover
from discern.rules.scene import Action, Scene
from discern.rules.verdict import JustificationNode, Verdict
from discern.sanity import reasoner_for
from tests.scenes import MPH, limit_sign, obj, scene, sensor


def unmarked_crossroads(x: float) -> Scene:
    """A car of unknown speed on the cross road, x metres to the side, at a crossroads nothing controls."""
    kind = "cross_right" if x > 0 else "cross_left"
    return scene(speed=10.0, limit=13.4, other_lanes=("cross_left", "cross_right"),
                 objects=[obj("car", x, 8.0, 1, oid=1, kind=kind, sources=("camera", "radar"))],
                 intersection={"type": "unsignaled", "stage": "arriving", "distance": 6.0})


def exit_sign(x: float) -> Scene:
    """The middle lane of three on a highway, the right one an exit 150 m on; a 25 mph sign x metres to the side."""
    return scene(speed=30.0, lane=2, lanes=3, zone="highway", limit=None, lane_ends={3: 150.0}, exits=(3,),
                 signs=[{**limit_sign(25), "position": {"x": x, "y": 60.0}}],
                 objects=[obj("truck", 0.0, -5.0, 2, oid=2, vy=30.0, sources=("camera", "radar"))])


@dataclass(frozen=True)
class Example:
    rule: str
    situation: str  # what happens, in a sentence
    frames: tuple[Scene, ...]  # the window, oldest first; the last one is decided
    proposed: Action
    blocked: Optional[tuple[Scene, ...]]  # a near miss where the rule does not fire
    jurisdiction: str = "us"
    blocked_jurisdiction: Optional[str] = None

    def reasoners(self) -> tuple[Reasoner, Reasoner]:
        return reasoner_for(self.jurisdiction), reasoner_for(self.blocked_jurisdiction or self.jurisdiction)


def fired(reasoner: Reasoner, frames: tuple[Scene, ...], proposed: Action = Action.cruise) -> set[str]:
    """Ids of the rules with an instance whose body holds in the last frame's answer set."""
    solved = reasoner.solve(frames[-1], proposed, history=frames[:-1])
    return Prover(reasoner.catalog, solved.answer, given=reasoner.frame_predicates).fired_rules()


def conclusion(reasoner: Reasoner, frames: tuple[Scene, ...], proposed: Action, rule: str) -> Optional[JustificationNode]:
    """The proof of the first atom `rule` derives in the last frame (None for facts and rules that did not fire)."""
    solved = reasoner.solve(frames[-1], proposed, history=frames[:-1])
    prover = Prover(reasoner.catalog, solved.answer, given=reasoner.frame_predicates)
    for compiled in reasoner.catalog.compiled:
        if compiled.info.id != rule:
            continue
        for sym in solved.answer.of(*compiled.signature):
            for candidate, env in prover.derivations(sym):
                if candidate.info.id == rule:
                    return prover.node_for(candidate, env, sym)
    facts = [sym for sym, owner in reasoner.catalog.fact_rule.items() if owner == rule]
    if facts:
        phrases = prover.phrases
        return JustificationNode(literal=rule, holds=True, rule=rule, kind="fact",
                                 text="; ".join(sorted(phrases.atom(s) for s in facts)))
    return None


def render(node: JustificationNode, depth: int = 0, max_depth: int = 4) -> list[str]:
    """The proof as indented lines, cut below `max_depth`."""
    rule = f"  [{node.rule}]" if node.rule and node.kind != "blocked" else ""
    lines = ["  " * depth + "- " + node.text + rule]
    if depth < max_depth:
        for child in node.children:
            lines.extend(render(child, depth + 1, max_depth))
    elif node.children:
        lines.append("  " * (depth + 1) + "- ...")
    return lines


def decide(example: Example) -> Verdict:
    reasoner, _ = example.reasoners()
    return reasoner.decide(example.frames[-1], example.proposed, history=example.frames[:-1], explain=True)


BEGIN, END = "<!-- examples: python -m tests.worked_examples docs/sanity.md -->", "<!-- /examples -->"


def markdown(examples: list[Example]) -> str:
    out = []
    for example in examples:
        reasoner, _ = example.reasoners()
        verdict = decide(example)
        node = conclusion(reasoner, example.frames, example.proposed, example.rule)
        info = reasoner.catalog.by_id[example.rule]
        window = f" ({len(example.frames)} frames)" if len(example.frames) > 1 else ""
        out += [
            f"### `{example.rule}`",
            "",
            f"*{info.says}* Source: {info.source}.",
            "",
            f"{example.situation}{window} Jurisdiction: {example.jurisdiction.upper()}. "
            f"Proposed: `{example.proposed.value}`.",
            "",
            "```",
            verdict.justification.summary,
            "what the rule concludes:",
            *(render(node) if node is not None else ["(no instance)"]),
            "```",
            "",
        ]
    return "\n".join(out)


def _examples() -> list[Example]:
    city_85 = (scene(speed=16.0, limit=85 * MPH, signs=[limit_sign(85)]),)
    road_45 = [scene(frame=i, speed=20.2, zone="road", limit=45 * MPH, signs=[limit_sign(45)]) for i in (1, 2)]
    road_55 = scene(frame=3, speed=20.2, zone="road", limit=55 * MPH, signs=[limit_sign(55)])
    truck_behind = (obj("truck", 0.0, -5.0, 1, oid=2, vy=31.0, sources=("camera", "radar")),)
    highway_70 = [scene(frame=i, speed=31.0, zone="highway", limit=70 * MPH, signs=[limit_sign(70)], objects=truck_behind)
                  for i in (1, 2, 3)]
    highway_40 = scene(frame=4, speed=31.0, zone="highway", limit=40 * MPH, signs=[limit_sign(40)], objects=truck_behind)

    def highway_35_then_85(**extra) -> tuple[Scene, ...]:
        """A highway's 35 mph read in three frames, then a sign taped to read 85 in three; the ego drives 15.6 m/s."""
        return tuple(scene(frame=i, speed=15.6, zone="highway", limit=None, signs=[limit_sign(35 if i < 4 else 85)],
                           **extra) for i in range(1, 7))

    stop_line = {"type": "unsignaled", "stage": "arriving", "distance": 30.0, "stop_line": True}
    at_stop = {"type": "four_way", "stage": "at", "distance": 0.0}
    arriving = {"type": "four_way", "stage": "arriving", "distance": 12.0}  # within a comfortable stop (def.line_far_ahead)
    radar_car = obj("car", -3.5, 40.0, 1, oid=2, vy=15.0, sources=("camera", "radar"))
    phantom = obj("car", 0.0, 16.0, 2, oid=9, vy=5.0, sources=("camera",))
    real_ahead = obj("car", 0.0, 16.0, 2, oid=9, vy=5.0, sources=("camera", "radar"))
    hw = {"zone": "highway", "limit": 29.0, "lanes": 2, "lane": 2, "speed": 15.0}
    truck = obj("truck", 0.0, 30.0, 1, oid=2, vy=12.0, size={"length": 12.0, "width": 2.5}, sources=("camera", "radar"))
    toy_car = obj("car", 0.0, 14.0, 1, oid=11, vy=0.0, sources=("camera",), size={"length": 0.7, "width": 0.3})
    # a flash is about 1 Hz: frames half a second apart see the light lit, dark, lit, dark (a 0.1 s gap is a lost
    # frame); perception lists it dark (colour none), since a light it does not list is out of view, not dark
    flashing_red = [scene(frame=i + 1, timestamp=0.5 * (i + 1), speed=8.0 - i, limit=11.0,
                          lights=[{"colour": "red" if i % 2 == 0 else "none"}], intersection=arriving) for i in range(4)]
    red_then_dark = tuple(flashing_red[:2])
    steady_red = (scene(frame=1, speed=8.0, limit=11.0, lights=[{"colour": "red"}], intersection=arriving),
                  scene(frame=2, speed=7.0, limit=11.0, lights=[{"colour": "red"}], intersection=arriving))
    ambulance = [scene(frame=i + 1, speed=12.0, lanes=2, limit=15.0,
                       objects=[obj("emergency_vehicle", 0.0, -40.0 + 2 * i, 1, oid=4, vy=20.0, emergency_lights=on,
                                    sources=("camera", "radar"))])
                 for i, on in enumerate([True, True, False])]
    glint = (scene(frame=1, speed=12.0, lanes=2, limit=15.0,
                   objects=[obj("car", 0.0, -40.0, 1, oid=4, vy=20.0, sources=("camera", "radar"))]),
             scene(frame=2, speed=12.0, lanes=2, limit=15.0,
                   objects=[obj("car", 0.0, -38.0, 1, oid=4, vy=20.0, emergency_lights=True,
                                sources=("camera", "radar"))]))
    school_bus = tuple(scene(frame=i + 1, speed=13.0, lane=2, lanes=2, limit=15.6, other_lanes=("shoulder",),
                             objects=[obj("bus", 3.5, 30.0 - i, 1, oid=4, kind="shoulder", vy=0.0,
                                          emergency_lights=True, sources=("camera", "radar"))])
                       for i in range(3))
    left_car = [scene(frame=i + 1, speed=12.0, lane=2, lanes=2, limit=15.0,
                      objects=[obj("car", -3.5, -12.8 + 0.8 * i, 1, oid=7, vy=20.0,
                                   sources=("camera", "radar"))]) for i in range(3)]
    lost = scene(frame=4, speed=12.0, lane=2, lanes=2, limit=15.0)
    # 12 m behind: the headway a car keeping pace at 12 m/s needs, so the reading alone does not take the lane
    lost_seen = scene(frame=4, speed=12.0, lane=2, lanes=2, limit=15.0, sensors=[sensor("rear_left", 12.0)])
    radar_lead = obj("car", -3.5, 40.0, 1, oid=2, vy=20.0, sources=("camera", "radar"))

    def undertake(offside_speed: float) -> Scene:
        return scene(speed=30.0, lane=1, lanes=3, zone="highway", limit=31.3,
                     objects=[obj("car", 3.5, 15.0, 2, oid=1, vy=offside_speed, sources=("camera", "radar"))])

    def undertake_tailgated(offside_speed: float) -> Scene:
        return scene(speed=30.0, lane=1, lanes=3, zone="highway", limit=31.3,
                     objects=[obj("car", 3.5, 15.0, 2, oid=1, vy=offside_speed, sources=("camera", "radar")),
                              obj("car", 0.0, -5.0, 1, oid=2, vy=30.0, sources=("camera", "radar"))])

    def amber(distance: float) -> Scene:
        return scene(speed=30 * MPH, limit=30 * MPH, lights=[{"colour": "yellow"}],
                     intersection={"type": "signaled", "stage": "arriving", "distance": distance})

    def left_turn_past(pedestrian_ahead: float) -> Scene:
        return scene(speed=0.0, limit=13.4, intent="enter_left_lane", lights=[{"colour": "green"}],
                     other_lanes=("oncoming", "cross_left", "sidewalk_left"),
                     intersection={"type": "signaled", "stage": "at", "distance": 0.0},
                     objects=[obj("pedestrian", -6.0, pedestrian_ahead, 1, oid=2, kind="sidewalk_left", vy=0.0,
                                  sources=("camera", "radar"))])

    def zebra(divided: bool) -> Scene:
        return scene(speed=10.0, limit=13.4, other_lanes=("oncoming", "cross_right"), divided_road=divided,
                     objects=[obj("pedestrian", 4.5, 12.0, 1, oid=1, kind="cross_right", vy=0.0,
                                  sources=("camera", "radar"))])

    def ghost_then_gone(sources: tuple) -> tuple[Scene, ...]:
        seen = [scene(frame=i + 1, speed=20.0, lane=2, lanes=2, zone="highway", limit=29.0,
                      objects=[radar_lead, obj("car", 0.0, 60.0 - 2.0 * i, 2, oid=9, vy=0.0, sources=sources)])
                for i in range(4)]
        return (*seen, scene(frame=5, speed=20.0, lane=2, lanes=2, zone="highway", limit=29.0, objects=[radar_lead]))

    def stopped_then_lost(front: float) -> tuple[Scene, ...]:
        """A standing car 24.8 to 20 m ahead at 12 m/s, camera and radar; then lost, the front radar reading `front` m."""
        seen = [scene(frame=i + 1, speed=12.0, limit=15.0,
                      objects=[obj("car", 0.0, 24.8 - 1.2 * i, 1, oid=1, vy=0.0, sources=("camera", "radar"))])
                for i in range(5)]
        return (*seen, scene(frame=6, speed=12.0, limit=15.0, sensors=[sensor("front", front)]))

    def stopped_then_renamed(front: float) -> tuple[Scene, ...]:
        """As `stopped_then_lost`, but the tracker has given the car's id to a car 80 m ahead on the left."""
        *seen, _ = stopped_then_lost(front)
        return (*seen, scene(frame=6, speed=12.0, limit=15.0,
                             objects=[obj("car", -3.5, 80.0, oid=1, vy=12.0, sources=("camera", "radar"))],
                             sensors=[sensor("front", front)]))

    walker = obj("pedestrian", 5.5, 22.0, oid=3, vy=0.0, vx=-1.5, sources=("camera", "lidar"))
    stroller = obj("pedestrian", 5.5, 22.0, oid=3, vy=1.2, vx=0.0, sources=("camera", "lidar"))
    pulling_out = obj("car", 6.0, 20.0, oid=7, vy=0.0, vx=-4.0, sources=("camera",))
    stop_sign = {"kind": "stop", "source": "camera"}
    dark_signal = {"type": "signaled", "stage": "arriving", "distance": 20.0, "stop_line": True}
    # a flashing red reported by perception, the ego slowing to a stop over four frames
    flashing_red_at = tuple(scene(frame=i, speed=max(0.0, 3.0 - i), limit=13.0, lights=[{"colour": "red", "flashing": True}],
                                  intersection=at_stop) for i in range(1, 5))
    # a flashing yellow left arrow beside a red ball, half a second on and off, dark now; the near miss: a steady one
    # hidden now, which is remembered but does not flash
    signal_line = {"type": "signaled", "stage": "at", "distance": 0.0}

    def left_arrow_beside_red(flashing: bool, lit: tuple[bool, ...]) -> tuple[Scene, ...]:
        arrow = {"colour": "yellow", "direction": "left", "flashing": flashing}
        return tuple(scene(frame=i + 1, timestamp=0.5 * i, speed=0.0, limit=13.0, intent="enter_left_lane", intersection=signal_line,
                           lights=[{"colour": "red"}, arrow] if on else [{"colour": "red"}]) for i, on in enumerate(lit))
    fya_dark = left_arrow_beside_red(True, (True, False, True, False))
    steady_arrow_dark = left_arrow_beside_red(False, (True, True, True, False))
    return [
        # --- speed limits
        Example("san.limit.sign", "No limit in the perceived state, but the camera reads a 25 mph sign; the ego drives 12 m/s.",
                (scene(speed=12.0, limit=None, signs=[limit_sign(25)]),), Action.accelerate,
                (scene(speed=12.0, limit=None),)),
        Example("san.limit.remembered", "A 30 mph sign was read for two frames and has left the view; the ego drives 13.5 m/s.",
                (scene(frame=1, speed=13.5, limit=None, signs=[limit_sign(30)]),
                 scene(frame=2, speed=13.5, limit=None, signs=[limit_sign(30)]), scene(frame=3, speed=13.5, limit=None)),
                Action.accelerate,
                (scene(frame=2, speed=13.5, limit=None, signs=[limit_sign(30)]), scene(frame=3, speed=13.5, limit=None))),
        Example("san.limit.map_bound", "On a road the sign reads 24 m/s but the map gives 20 m/s; the ego drives 21 m/s.",
                (scene(speed=21.0, zone="road", limit=24.0, map_speed_limit=20.0),), Action.accelerate,
                (scene(speed=21.0, zone="road", limit=24.0),)),
        Example("san.limit.implausible", "A taped sign in the city is read as 85 mph; the ego drives 16 m/s.",
                city_85, Action.accelerate, (scene(speed=16.0, limit=35 * MPH, signs=[limit_sign(35)]),)),
        Example("san.limit.large_rise",
                "On a highway a settled 35 mph sign is followed by one taped to read 85 mph, read in three frames; the "
                "ego drives 15.6 m/s (the near miss: the map gives 85 mph).",
                highway_35_then_85(), Action.accelerate, highway_35_then_85(map_speed_limit=85 * MPH)),
        Example("san.limit.unconfirmed", "A single frame reads 45 mph in the city, above the usual 35 mph; the ego drives 17 m/s.",
                (scene(speed=17.0, limit=45 * MPH),), Action.accelerate,
                (scene(frame=1, speed=17.0, limit=45 * MPH), scene(frame=2, speed=17.0, limit=45 * MPH))),
        Example("san.limit.debounce", "On a 45 mph road the reader shows 55 mph for one frame; the ego drives 20.2 m/s.",
                (*road_45, road_55), Action.accelerate,
                (road_45[1], road_55.model_copy(update={"frame_id": 4, "timestamp": 0.4}), road_55.model_copy(update={"frame_id": 5, "timestamp": 0.5}))),
        Example("san.limit.debounce_drop",
                "On a 70 mph highway the reader shows 40 mph for one frame; the ego drives 31 m/s with a truck 5 m behind.",
                (*highway_70, highway_40), Action.cruise,
                (*highway_70, highway_40, highway_40.model_copy(update={"frame_id": 5, "timestamp": 0.5}))),
        Example("san.limit.fallback_prior", "The one-frame 55 mph reading is doubted, so the 45 mph read before stays in force.",
                (*road_45, road_55), Action.accelerate, (road_55,)),
        Example("san.limit.highway_floor",
                "On a highway the camera reads a 5 mph sign; the ego drives 30 m/s with a truck 5 m behind.",
                (scene(speed=30.0, zone="highway", limit=None, signs=[limit_sign(5)],
                       objects=[obj("truck", 0.0, -5.0, 1, oid=2, vy=30.0, sources=("camera", "radar"))]),),
                Action.cruise,
                (scene(speed=30.0, zone="highway", limit=None, signs=[limit_sign(45)],
                       objects=[obj("truck", 0.0, -5.0, 1, oid=2, vy=30.0, sources=("camera", "radar"))]),)),
        Example("san.limit.exit_lane_sign",
                "At 30 m/s in the middle lane of a highway whose right lane is an exit, the camera reads a 25 mph sign "
                "standing 9 m to the right, past the exit lane, with a truck 5 m behind (the near miss: on the left verge).",
                (exit_sign(9.0),), Action.cruise, (exit_sign(-9.0),)),
        Example("san.limit.below_the_mapped_highway_limit",
                "On a highway the map says 70 mph and the camera reads a 25 mph sign; the ego drives 30 m/s with a "
                "truck 5 m behind (the near miss: the map says 25 mph too).",
                (scene(speed=30.0, zone="highway", limit=None, map_speed_limit=31.3, signs=[limit_sign(25)],
                       objects=[obj("truck", 0.0, -5.0, 1, oid=2, vy=30.0, sources=("camera", "radar"))]),),
                Action.cruise,
                (scene(speed=30.0, zone="highway", limit=None, map_speed_limit=11.2, signs=[limit_sign(25)],
                       objects=[obj("truck", 0.0, -5.0, 1, oid=2, vy=30.0, sources=("camera", "radar"))]),)),
        Example("san.limit.unusually_low",
                "In a city the camera reads a 5 mph sign in one frame; the ego drives 10 m/s.",
                (scene(speed=10.0, limit=None, signs=[limit_sign(5)]),), Action.cruise,
                (scene(speed=10.0, limit=None, signs=[limit_sign(15)]),)),
        Example("san.limit.school_sign_on_highway",
                "At 30 m/s on a 70 mph highway a school-zone sign is read (the near miss: on a rural road).",
                (scene(speed=30.0, zone="highway", limit=31.3, signs=[{"kind": "school_zone"}]),), Action.cruise,
                (scene(speed=24.0, zone="road", limit=24.6, signs=[{"kind": "school_zone"}]),)),
        Example("san.limit.school_sign_debounce", "On a rural road at 24.5 m/s, 55 mph read for three frames, a "
                "school-zone sign is detected in the fourth frame only.",
                tuple(scene(frame=i + 1, speed=24.5, zone="rural", limit=None,
                            signs=[limit_sign(55)] + ([{"kind": "school_zone"}] if i == 3 else [])) for i in range(4)),
                Action.cruise,
                tuple(scene(frame=i + 1, speed=24.5, zone="rural", limit=None,
                            signs=[limit_sign(55)] + ([{"kind": "school_zone"}] if i >= 1 else [])) for i in range(4))),
        Example("san.limit.low_confidence", "On a 70 mph highway (the map says 70) perception reads a 40 mph sign with 30 % "
                "confidence in one frame; the ego drives 31 m/s with a truck 6 m behind.",
                (scene(speed=31.0, zone="highway", limit=None, map_speed_limit=31.3,
                       signs=[{**limit_sign(40), "confidence": 0.3}],
                       objects=[obj("truck", 0.0, -6.0, 1, oid=9, vy=31.0, sources=("camera", "radar"))]),),
                Action.cruise,
                (scene(speed=31.0, zone="highway", limit=None, map_speed_limit=31.3,
                       signs=[{**limit_sign(40), "confidence": 0.9}],
                       objects=[obj("truck", 0.0, -6.0, 1, oid=9, vy=31.0, sources=("camera", "radar"))]),)),
        Example("san.limit.zero", "In a city the camera reads a limit of 0 in every frame for a second; the ego drives 10 m/s.",
                tuple(scene(frame=i + 1, timestamp=0.1 * i, speed=10.0, limit=None, signs=[limit_sign(0)])
                      for i in range(10)), Action.cruise,
                (scene(speed=10.0, limit=None, signs=[limit_sign(25)]),)),
        Example("san.limit.map_zero", "On a highway the map gives a limit of 0 (a limit it does not know); the camera reads "
                "70 mph, and the ego drives 30 m/s with a truck 5 m behind.",
                (scene(speed=30.0, zone="highway", limit=None, signs=[limit_sign(70)], map_speed_limit=0.0,
                       objects=[obj("truck", 0.0, -5.0, 1, oid=2, vy=30.0, sources=("camera", "radar"))]),),
                Action.cruise,
                (scene(speed=30.0, zone="highway", limit=None, signs=[limit_sign(70)], map_speed_limit=31.3,
                       objects=[obj("truck", 0.0, -5.0, 1, oid=2, vy=30.0, sources=("camera", "radar"))]),)),
        Example("san.limit.map_implausible", "In a city the map gives 85 mph (stale or wrong data) and no sign is read; "
                "the ego drives 20 m/s.",
                (scene(speed=20.0, limit=None, map_speed_limit=85 * MPH),), Action.accelerate,
                (scene(speed=20.0, limit=None, map_speed_limit=45 * MPH),)),
        Example("san.limit.map_implausibly_low", "On a highway the map gives 5 mph (a wrong map tile) while the camera "
                "reads 70 mph; the ego drives 30 m/s with a truck 6 m behind.",
                (scene(speed=30.0, zone="highway", limit=None, signs=[limit_sign(70)], map_speed_limit=5 * MPH,
                       objects=[obj("truck", 0.0, -6.0, 1, oid=2, vy=30.0, sources=("camera", "radar"))]),),
                Action.cruise,
                (scene(speed=30.0, zone="highway", limit=None, signs=[limit_sign(70)], map_speed_limit=55 * MPH,
                       objects=[obj("truck", 0.0, -6.0, 1, oid=2, vy=30.0, sources=("camera", "radar"))]),)),
        Example("san.limit.fallback_zone", "The taped 85 mph city sign, with no map and nothing read before.",
                city_85, Action.accelerate, (scene(speed=16.0, limit=85 * MPH, map_speed_limit=15.0),)),
        Example("san.limit.zone_default", "Nothing tells the limit in a city; the ego drives 16 m/s.",
                (scene(speed=16.0, limit=None),), Action.accelerate, (scene(speed=16.0, limit=15.0),)),
        # --- stop signs
        Example("san.stop.evidence_map", "The map marks the approach stop-controlled.",
                (scene(limit=11.0, intersection={"type": "four_way", "stage": "arriving", "stop_controlled": True}),),
                Action.cruise, (scene(limit=11.0, intersection=arriving),)),
        Example("san.stop.evidence_line", "A stop line at an intersection with no traffic lights.",
                (scene(limit=11.0, intersection=stop_line),), Action.cruise,
                (scene(limit=11.0, intersection=stop_line, traffic_lights=[{"colour": "green"}]),)),
        Example("san.stop.evidence_traffic", "Cross traffic drives through an unsignalised intersection ahead.",
                (scene(limit=11.0, intersection=arriving, other_lanes=("cross_left",),
                       objects=[obj("car", -15.0, 25.0, 1, oid=5, kind="cross_left", vy=0.0, vx=10.0,
                                    sources=("camera", "radar"))]),),
                Action.cruise,
                (scene(limit=11.0, intersection=arriving, other_lanes=("cross_left",),
                       objects=[obj("car", -15.0, 25.0, 1, oid=5, kind="cross_left", vy=0.0, vx=0.0,
                                    sources=("camera", "radar"))]),)),
        Example("san.stop.misread_sign", "Stickers make the camera read a stop sign as \"speed limit 45\" at a stop line.",
                (scene(limit=25 * MPH, signs=[limit_sign(45)], intersection=stop_line),), Action.accelerate,
                (scene(limit=25 * MPH, signs=[limit_sign(45)], intersection={**stop_line, "stop_line": False}),)),
        Example("san.stop.misread_limit", "The misread stop sign's \"45\" is not taken as a limit.",
                (scene(limit=None, signs=[limit_sign(45)], intersection=stop_line),), Action.accelerate,
                (scene(limit=None, signs=[limit_sign(45)]),)),
        Example("san.stop.map_controlled", "No stop sign is seen, but the map marks the approach stop-controlled.",
                (scene(limit=11.0, intersection={"type": "four_way", "stage": "arriving", "stop_controlled": True}),),
                Action.cruise, (scene(limit=11.0, intersection={"type": "four_way", "stage": "arriving"}),)),
        Example("san.stop.line_controlled", "At the stop line of a crossing without lights, no stop sign seen, the ego rolls on at 4 m/s.",
                (scene(speed=4.0, limit=11.0, intersection={**stop_line, "stage": "at", "distance": 0.0}),),
                Action.cruise,
                (scene(speed=4.0, limit=11.0, intersection={**stop_line, "stage": "at", "distance": 0.0, "stop_line": False}),)),
        Example("san.memory.stop_sign", "A stop sign seen two frames ago is hidden by a truck now.",
                (scene(frame=1, limit=11.0, signs=[stop_sign], intersection=arriving),
                 scene(frame=2, limit=11.0, intersection=arriving)), Action.cruise,
                (scene(frame=1, limit=11.0, intersection=arriving), scene(frame=2, limit=11.0, intersection=arriving))),
        Example("san.memory.school_zone_sign",
                "A school-zone sign was read in three frames on a 45 mph road and has just left the view; the ego drives "
                "15 m/s.",
                tuple(scene(frame=i + 1, speed=15.0, zone="road", limit=45 * MPH, signs=[{"kind": "school_zone"}])
                      for i in range(3)) + (scene(frame=4, speed=15.0, zone="road", limit=45 * MPH),), Action.accelerate,
                (scene(frame=1, speed=15.0, zone="road", limit=45 * MPH), scene(frame=2, speed=15.0, zone="road", limit=45 * MPH))),
        # --- range sensors over the camera
        Example("san.radar.confirmed_earlier", "Only the camera reports the car ahead now, but the radar reported it a frame ago.",
                (scene(frame=1, **hw, objects=[radar_car, real_ahead]),
                 scene(frame=2, **hw, objects=[radar_car, phantom])), Action.cruise,
                (scene(frame=1, **hw, objects=[radar_car, phantom]), scene(frame=2, **hw, objects=[radar_car, phantom]))),
        Example("san.radar.camera_missed", "The camera misses the slow car 16 m ahead that the radar reports; it sees the car in the next lane.",
                (scene(**hw, objects=[radar_car, {**real_ahead, "sources": ["radar"]}]),), Action.cruise,
                (scene(**hw, objects=[radar_car, real_ahead]),)),
        Example("san.radar.phantom", "The camera reports a slow car 16 m ahead that the running radar does not see.",
                (scene(**hw, objects=[radar_car, phantom]),), Action.cruise, (scene(**hw, objects=[phantom]),)),
        Example("san.radar.phantom_caution", "The possible phantom is in the ego's lane within the gap needed.",
                (scene(**hw, objects=[radar_car, phantom]),), Action.accelerate,
                (scene(**hw, objects=[radar_car, {**phantom, "position": {"x": 0.0, "y": 30.0}}]),)),
        Example("san.radar.ranged_past", "The possible phantom in the ego's lane, 16 m ahead, and the front radar reads "
                "clear road to 60 m.",
                (scene(**hw, objects=[radar_car, phantom], sensors=[sensor("front", 60.0)]),), Action.cruise,
                (scene(**hw, objects=[radar_car, phantom], sensors=[sensor("front", 10.0)]),)),
        Example("san.radar.read_past_close", "Only the camera reports a car standing 12 m ahead in the ego's lane, too close to "
                "wait for the radar; the front radar reads clear road to 60 m.",
                (scene(**hw, objects=[radar_car, {**phantom, "position": {"x": 0.0, "y": 12.0}, "velocity": {"x": 0.0, "y": 0.0}}],
                       sensors=[sensor("front", 60.0)]),), Action.cruise,
                (scene(**hw, objects=[radar_car, {**phantom, "position": {"x": 0.0, "y": 12.0}, "velocity": {"x": 0.0, "y": 0.0}}]),)),
        Example("san.caution.slow_down", "Caution for a possible phantom calls for slowing down.",
                (scene(**hw, objects=[radar_car, phantom]),), Action.cruise, (scene(**hw, objects=[radar_car]),)),
        Example("san.caution.no_speeding_up", "Caution for a possible phantom forbids accelerating.",
                (scene(**hw, objects=[radar_car, phantom]),), Action.accelerate, (scene(**hw, objects=[radar_car]),)),
        Example("san.radar.left_lane_taken", "The camera sees the left lane empty; the left radar reads 2.0 m.",
                (scene(speed=12.0, lane=2, lanes=2, limit=15.0, sensors=[sensor("left", 2.0)]),), Action.change_lane_left,
                (scene(speed=12.0, lane=2, lanes=2, limit=15.0, sensors=[sensor("left", 4.0)]),)),
        Example("san.radar.right_lane_taken", "The camera sees the right lane empty; the rear-right radar reads 6 m.",
                (scene(speed=12.0, lane=1, lanes=2, limit=15.0, sensors=[sensor("rear_right", 6.0)]),), Action.change_lane_right,
                (scene(speed=12.0, lane=1, lanes=2, limit=15.0, sensors=[sensor("rear_right", 25.0)]),)),
        Example("san.radar.kerb_taken", "The route asks to pull over; the camera sees the shoulder empty; the right radar "
                "reads 2.0 m.",
                (scene(speed=12.0, lane=2, lanes=2, limit=15.0, intent="pull_over", other_lanes=("shoulder",),
                       sensors=[sensor("right", 2.0)]),),
                Action.pull_over,
                (scene(speed=12.0, lane=2, lanes=2, limit=15.0, intent="pull_over", other_lanes=("shoulder",),
                       sensors=[sensor("right", 4.0)]),)),
        Example("san.radar.side_contact", "The lane ends at a barrier the camera reads as a lane marking; the left sensor reads 0.4 m.",
                (scene(speed=27.0, zone="highway", limit=29.0, lanes=2, sensors=[sensor("left", 0.4, "ultrasonic")]),),
                Action.cruise,
                (scene(speed=27.0, zone="highway", limit=29.0, lanes=2, sensors=[sensor("left", 0.8, "ultrasonic")]),)),
        Example("san.range.beyond_reach",
                "On a highway the front ultrasonic sensor reads 60 m; the front radar reads 90 m, where it reports a car.",
                (scene(speed=29.0, zone="highway", limit=29.0,
                       objects=[obj("car", 0.0, 90.0, 1, oid=8, vy=29.0, sources=("camera", "radar"))],
                       sensors=[sensor("front", 60.0, "ultrasonic"), sensor("front", 90.0)]),), Action.cruise,
                (scene(speed=29.0, zone="highway", limit=29.0,
                       objects=[obj("car", 0.0, 90.0, 1, oid=8, vy=29.0, sources=("camera", "radar"))],
                       sensors=[sensor("front", 8.0, "ultrasonic"), sensor("front", 90.0)]),)),
        Example("san.lane.position_over_label",
                "The lidar confirms a pedestrian 5 m straight ahead that perception labels as on the right sidewalk.",
                (scene(speed=10.0, limit=15.0, other_lanes=("sidewalk_right",),
                       objects=[obj("pedestrian", 0.0, 5.0, 1, oid=1, kind="sidewalk_right",
                                    sources=("camera", "lidar"))]),),
                Action.accelerate,
                (scene(speed=10.0, limit=15.0, other_lanes=("sidewalk_right",),
                       objects=[obj("pedestrian", 5.5, 5.0, 1, oid=1, kind="sidewalk_right",
                                    sources=("camera", "lidar"))]),)),
        # --- multiple worlds
        Example("san.world.elevated", "A car on a billboard: its base is 4.5 m above the road, 9 m ahead.",
                (scene(speed=12.0, limit=15.0,
                       objects=[obj("car", 0.0, 9.0, 1, oid=6, sources=("camera",), elevation=4.5)]),),
                Action.cruise,
                (scene(speed=12.0, limit=15.0,
                       objects=[obj("car", 0.0, 9.0, 1, oid=6, sources=("camera",), elevation=0.2)]),)),
        Example("san.world.picture_on_object", "A car painted on the back of a truck: only the camera sees it, inside the truck's outline.",
                (scene(speed=12.0, limit=15.0, objects=[truck, obj("car", 0.3, 30.2, 1, oid=5, sources=("camera",))]),),
                Action.accelerate,
                (scene(speed=12.0, limit=15.0,
                       objects=[truck, obj("car", 0.3, 30.2, 1, oid=5, sources=("camera", "radar"))]),)),
        Example("san.world.sign_on_a_vehicle", "On a 70 mph highway a \"40\" sticker on the back of a truck 70 m ahead is "
                "read as a speed-limit sign; the ego drives 31 m/s with another truck 6 m behind.",
                (scene(speed=31.0, zone="highway", limit=None, map_speed_limit=31.3,
                       signs=[{**limit_sign(40), "position": {"x": 0.0, "y": 72.0}}],
                       objects=[obj("truck", 0.0, 70.0, 1, oid=3, vy=31.0, sources=("camera", "radar")),
                                obj("truck", 0.0, -6.0, 1, oid=9, vy=31.0, sources=("camera", "radar"))]),),
                Action.cruise,
                (scene(speed=31.0, zone="highway", limit=None, map_speed_limit=31.3,
                       signs=[{**limit_sign(40), "position": {"x": 8.0, "y": 72.0}}],
                       objects=[obj("truck", 0.0, 70.0, 1, oid=3, vy=31.0, sources=("camera", "radar")),
                                obj("truck", 0.0, -6.0, 1, oid=9, vy=31.0, sources=("camera", "radar"))]),)),
        Example("san.world.size", "A toy-sized car, 0.7 m long, standing 14 m ahead, that only the camera reports, while "
                "the front radar reads clear road for 60 m; without the radar reading, the same toy is braked for.",
                (scene(speed=8.0, limit=15.0, objects=[toy_car], sensors=[sensor("front", 60.0)]),),
                Action.accelerate,
                (scene(speed=8.0, limit=15.0, objects=[toy_car]),)),
        Example("san.world.no_echo_off_lane", "A car only the camera sees, on no lane, while the radar is running (a roadside advert).",
                (scene(speed=12.0, limit=15.0,
                       objects=[obj("car", 0.0, 40.0, 1, oid=2, vy=12.0, sources=("camera", "radar")),
                                obj("car", 6.0, 9.0, oid=8, sources=("camera",), predicted_path="op1")],
                       path_crossings=[{"ego_path": "sp1", "object_path": "op1"}],
                       ego={"speed": 12.0, "lane": 1, "predicted_path": "sp1"}),),
                Action.cruise,
                (scene(speed=12.0, limit=15.0,
                       objects=[obj("car", 6.0, 9.0, oid=8, sources=("camera",), predicted_path="op1")],
                       path_crossings=[{"ego_path": "sp1", "object_path": "op1"}],
                       ego={"speed": 12.0, "lane": 1, "predicted_path": "sp1"}),)),
        # --- the frame window
        Example("san.lights.flashing", "A red light seen on, off, on, off over four frames half a second apart.",
                tuple(flashing_red), Action.cruise, steady_red),
        Example("san.lights.flashing_not_steady", "The flashing red light is no steady red.",
                tuple(flashing_red), Action.cruise, steady_red),
        Example("san.lights.flashing_red_stop", "Arriving at an intersection whose light flashes red.",
                tuple(flashing_red), Action.cruise, steady_red),
        Example("san.lights.flashing_arrow_governs",
                "Stopped at the line to turn left, beside a steady red ball, the ego sees a yellow left arrow perception "
                "reports flashing, dark now between flashes.", fya_dark, Action.turn_left, steady_arrow_dark),
        Example("san.lights.dark_signal",
                "The traffic lights of the intersection 20 m ahead are all dark; the ego drives 12 m/s (US: an all-way stop).",
                (scene(speed=12.0, limit=15.6, lights=[{"colour": "none"}], intersection=dark_signal),), Action.accelerate,
                (scene(speed=12.0, limit=15.6, lights=[{"colour": "green"}], intersection=dark_signal),)),
        Example("san.memory.red_light", "A red light seen a frame ago is dark now (not yet known to be flashing).",
                red_then_dark, Action.cruise, steady_red),
        Example("san.memory.yellow_light", "A steady yellow seen a frame ago is hidden now; the ego can still stop before the line.",
                tuple(scene(frame=i + 1, speed=10.0, limit=13.4, lights=[{"colour": "yellow"}] if i == 0 else [],
                            intersection={**arriving, "distance": 30.0 - i}) for i in range(2)),
                Action.cruise,
                tuple(scene(frame=i + 1, speed=10.0, limit=13.4, lights=[{"colour": "yellow", "flashing": True}] if i == 0 else [],
                            intersection={**arriving, "distance": 30.0 - i}) for i in range(2))),
        Example("san.lights.flashing_yellow_caution", "A yellow light reported flashing.",
                (scene(speed=9.0, limit=11.0, lights=[{"colour": "yellow", "flashing": True}]),), Action.accelerate,
                (scene(speed=9.0, limit=11.0, lights=[{"colour": "green"}]),)),
        Example("san.emergency.flashing", "An ambulance behind shows its lights in two of three frames.",
                tuple(ambulance), Action.cruise, glint),
        Example("san.emergency.give_way", "The ambulance on duty closes in from behind.",
                tuple(ambulance), Action.cruise, glint),
        Example("san.emergency.pull_over", "The ambulance on duty closes in from behind; the ego is in the kerb lane.",
                tuple(s.model_copy(update={"ego": s.ego.model_copy(update={"lane": 2})}) for s in ambulance),
                Action.cruise, glint),
        Example("san.emergency.move_to_kerb", "The ambulance on duty closes in; the ego is in the left lane of two.",
                tuple(ambulance), Action.cruise, glint),
        Example("san.emergency.move_over",
                "A police car stands on the right shoulder 75 m ahead, lights flashing; the ego is in the right lane.",
                tuple(scene(frame=i + 1, speed=25.0, lane=2, lanes=2, zone="highway", limit=29.0, other_lanes=("shoulder",),
                            objects=[obj("emergency_vehicle", 3.5, 79.0 - 2 * i, 1, oid=9, kind="shoulder", vy=0.0,
                                         emergency_lights=True, sources=("camera", "radar"))]) for i in range(3)),
                Action.cruise,
                tuple(scene(frame=i + 1, speed=25.0, lane=2, lanes=2, zone="highway", limit=29.0, other_lanes=("shoulder",),
                            objects=[obj("emergency_vehicle", 3.5, 79.0 - 2 * i, 1, oid=9, kind="shoulder", vy=0.0,
                                         sources=("camera", "radar"))])
                      for i in range(3))),
        Example("san.school_bus.stop",
                "A bus stands at the right kerb 30 m ahead, red lights flashing; the ego could pass it in the left lane.",
                school_bus,
                Action.change_lane_left,
                tuple(scene(frame=i + 1, speed=13.0, lane=2, lanes=2, limit=15.6, other_lanes=("shoulder",),
                            objects=[obj("bus", 3.5, 30.0 - i, 1, oid=4, kind="shoulder", vy=0.0,
                                         sources=("camera", "radar"))])
                      for i in range(3))),
        Example("jur.us.school_bus_law",
                "The school bus at the right kerb again, red lights flashing; under the US pack the ego stops behind it "
                "(under the UK's it passes slowly).",
                school_bus, Action.cruise, school_bus, "us", "uk"),
        Example("san.memory.object_permanence", "The camera loses a faster car in the left lane; the rear-left radar still reads it.",
                (*left_car, lost_seen), Action.change_lane_left, (left_car[2], lost)),
        Example("san.memory.phantom_lost",
                "Only the camera reported a standing car 60 m ahead for 0.4 s, while the radar reported the car in the "
                "next lane; now the camera has lost it too (the near miss: the radar had reported it as well).",
                ghost_then_gone(("camera",)), Action.cruise, ghost_then_gone(("camera", "radar"))),
        Example("san.memory.range_clears",
                "The camera loses a car standing 20 m ahead that it and the radar reported; the front radar now reads "
                "clear road 60 m ahead, so the car is let go (the near miss: the radar reads 19 m, where the car is).",
                stopped_then_lost(60.0), Action.accelerate, stopped_then_lost(19.0)),
        Example("san.memory.id_reused",
                "The camera loses a car standing 20 m ahead, and the tracker gives its id to a car 80 m ahead on the "
                "left; the front radar still reads 19 m, so the standing car is kept, as the car once tracked as 1 (the near miss: the "
                "radar reads clear road 60 m ahead, and it is let go).",
                stopped_then_renamed(19.0), Action.accelerate, stopped_then_renamed(60.0)),
        Example("san.track.predicted_crossing", "A pedestrian on the right walks towards the road, 22 m ahead.",
                (scene(speed=8.0, limit=11.0, objects=[walker]),), Action.cruise,
                (scene(speed=8.0, limit=11.0, objects=[stroller]),)),
        Example("san.track.phantom_crossing_caution",
                "Only the camera sees a car pulling out from the right, 20 m ahead, while the radar reports the lead car.",
                (scene(speed=10.0, limit=13.4, objects=[radar_car, pulling_out]),), Action.accelerate,
                (scene(speed=10.0, limit=13.4, objects=[radar_car, {**pulling_out, "velocity": {"x": 0.0, "y": 0.0}}]),)),
        Example("san.track.stepped_crossing",
                "A child runs across from the right, 18 m ahead, at 3 m/s: at the ego's 10 m/s they clear its path just "
                "before it gets there, one step of accelerating faster they would not (the near miss: 24 m ahead, they "
                "clear it either way).",
                (scene(speed=10.0, limit=11.2,
                       objects=[obj("pedestrian", 3.5, 18.0, oid=3, vy=0.0, vx=-3.0, sources=("camera", "lidar"))]),),
                Action.accelerate,
                (scene(speed=10.0, limit=11.2,
                       objects=[obj("pedestrian", 3.5, 24.0, oid=3, vy=0.0, vx=-3.0, sources=("camera", "lidar"))]),)),
        # --- jurisdictions
        Example("jur.us", "Any scene under the US pack.", (scene(limit=13.0),), Action.cruise, (scene(limit=13.0),),
                "us", "uk"),
        Example("jur.right_hand_traffic", "Any scene under the US pack.", (scene(limit=13.0),), Action.cruise,
                (scene(limit=13.0),), "us", "uk"),
        Example("jur.us.kerb_side", "Any scene under the US pack.", (scene(limit=13.0),), Action.cruise,
                (scene(limit=13.0),), "us", "uk"),
        Example("jur.us.lane_preference", "A roadblock in the middle lane of three; both neighbouring lanes are free.",
                (scene(lanes=3, lane=2, objects=[obj("roadblock", 0.0, 15.0, 2, oid=1, sources=("camera", "radar"))],
                       limit=13.0),), Action.cruise,
                (scene(lanes=3, lane=2, objects=[obj("roadblock", 0.0, 15.0, 2, oid=1, sources=("camera", "radar"))],
                       limit=13.0),), "us", "uk"),
        Example("jur.us.zone_limits", "Nothing tells the limit in a US city.", (scene(speed=16.0, limit=None),),
                Action.accelerate, (scene(speed=16.0, limit=None),), "us", "uk"),
        Example("jur.us.right_on_red", "Stopped at a red light with a right turn to make (US).",
                (scene(speed=0.0, limit=11.0, intent="enter_right_lane", lights=[{"colour": "red"}], intersection=at_stop),),
                Action.turn_right,
                (scene(speed=4.0, limit=11.0, intent="enter_right_lane", lights=[{"colour": "red"}], intersection=at_stop),)),
        Example("jur.us.school_sign_strict",
                "A school-zone sign on a city street, the ego at 10 m/s (22.4 mph) against the sign's 20 mph: within "
                "the 5 mph margin kept elsewhere, but a school zone's limit is kept strictly (the near miss: a plain "
                "20 mph limit, which the margin lets the ego hold 22.4 mph under).",
                (scene(speed=10.0, limit=15.6, signs=[{"kind": "school_zone"}]),), Action.cruise,
                (scene(speed=10.0, limit=20 * MPH),)),
        Example("jur.us.flashing_red",
                "Stopped at the line of an intersection whose light flashes red (US: a stop sign; under the UK's pack "
                "the ego waits while it flashes).",
                flashing_red_at, Action.accelerate, flashing_red_at, "us", "uk"),
        Example("jur.us.dark_signal",
                "The lights of the intersection ahead are all dark (US: an all-way stop; under the UK's pack an unmarked "
                "junction, passed with great care).",
                (scene(speed=12.0, limit=15.6, lights=[{"colour": "none"}], intersection=dark_signal),), Action.accelerate,
                (scene(speed=12.0, limit=15.6, lights=[{"colour": "none"}], intersection=dark_signal),), "us", "uk"),
        Example("jur.us.uncontrolled_junction",
                "Arriving at 10 m/s, 6 m from the line of a crossroads no light or sign controls; a car of unknown speed "
                "is 10 m to the right on the cross road (US).",
                (unmarked_crossroads(10.0),), Action.accelerate, (unmarked_crossroads(10.0),), "us", "uk"),
        Example("jur.uk", "Any scene under the UK pack.", (scene(limit=13.0),), Action.cruise, (scene(limit=13.0),),
                "uk", "us"),
        Example("jur.uk.unmarked_junction",
                "Arriving at 10 m/s, 6 m from the line of an unmarked crossroads; a car of unknown speed is 30 m to the "
                "left on the cross road (UK).",
                (unmarked_crossroads(-30.0),), Action.accelerate, (unmarked_crossroads(-30.0),), "uk", "us"),
        Example("jur.left_hand_traffic", "A slower truck ahead on a UK motorway: overtake on the right.",
                (scene(speed=20.0, zone="highway", limit=29.0, lanes=2,
                       objects=[obj("truck", 0.0, 30.0, 1, oid=1, vy=15.0, sources=("camera", "radar"))]),),
                Action.cruise, (scene(limit=13.0),), "uk", "us"),
        Example("jur.uk.kerb_side", "An emergency vehicle on duty behind; the UK kerb is on the left.",
                (scene(speed=12.0, lane=2, lanes=2, limit=13.0,
                       objects=[obj("emergency_vehicle", 0.0, -30.0, 2, oid=4, vy=20.0, emergency_lights=True,
                                    sources=("camera", "radar"))]),),
                Action.cruise, (scene(limit=13.0),), "uk", "us"),
        Example("jur.uk.lane_preference", "A roadblock in the middle lane of three (UK).",
                (scene(lanes=3, lane=2, objects=[obj("roadblock", 0.0, 15.0, 2, oid=1, sources=("camera", "radar"))],
                       limit=13.0),), Action.cruise,
                (scene(lanes=3, lane=2, objects=[obj("roadblock", 0.0, 15.0, 2, oid=1, sources=("camera", "radar"))],
                       limit=13.0),), "uk", "us"),
        Example("jur.uk.no_overtaking_on_the_left",
                "On a UK motorway at 30 m/s in the left lane, a car at 22 m/s is 15 m ahead in the lane on the right "
                "(the near miss: it keeps the ego's pace).",
                (undertake(22.0),), Action.accelerate, (undertake(30.0),), "uk"),
        Example("jur.uk.drop_back_not_undertake",
                "On a UK motorway at 30 m/s in the left lane, a car at 22 m/s is 15 m ahead in the lane on the right "
                "and a car follows 5 m behind: the ego slows to stay behind the car on the right, and braking is not "
                "braking for nothing (the near miss: the car on the right does 29 m/s, within the speed margin).",
                (undertake_tailgated(22.0),), Action.brake, (undertake_tailgated(29.0),), "uk"),
        Example("jur.uk.amber_light",
                "At 30 mph a UK light turns amber 35 m before the line: the ego can stop, braking firmly, though not "
                "comfortably (the near miss: 20 m before the line it cannot stop, and goes on).",
                (amber(35.0),), Action.cruise, (amber(20.0),), "uk"),
        Example("jur.uk.waiting_to_cross",
                "Stopped at a green in the UK to turn left, a pedestrian stands on the pavement at the corner of the "
                "road the ego turns into, 6 m ahead (the near miss: 30 m up the pavement, past the corner).",
                (left_turn_past(6.0),), Action.turn_left, (left_turn_past(30.0),), "uk"),
        Example("jur.uk.zebra_whole_crossing",
                "A pedestrian stands on a zebra crossing 12 m ahead, on the far half of an undivided UK road (the "
                "near miss: a central refuge divides the road).",
                (zebra(False),), Action.cruise, (zebra(True),), "uk"),
        Example("jur.uk.zone_limits", "Nothing tells the limit in a UK town; the ego drives 14 m/s.",
                (scene(speed=14.0, limit=None),), Action.accelerate, (scene(speed=14.0, limit=None),), "uk", "us"),
    ]


EXAMPLES = _examples()


def write_into(path: Path) -> None:
    """Replace the examples block of a markdown file with freshly generated examples.

    Raises ValueError for a file without the block, OSError for one that cannot be read or written.
    """
    text = path.read_text(encoding="utf-8")
    start, end = text.find(BEGIN), text.find(END)
    if start < 0 or end < start:
        raise ValueError(f"{path}: no examples block ({BEGIN} ... {END})")
    path.write_text(text[: start + len(BEGIN)] + "\n\n" + markdown(EXAMPLES) + "\n" + text[end:], encoding="utf-8")


def main(argv: Optional[list[str]] = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m tests.worked_examples",
        description="One worked example per sanity and jurisdiction rule, each with the engine's justification, "
        "as markdown: written into a file's examples block, or to stdout.")
    parser.add_argument("markdown", nargs="?", type=Path, metavar="FILE",
                        help="a markdown file whose examples block (from the line " + BEGIN.replace("%", "%%")
                        + " to " + END + ") is replaced, e.g. docs/sanity.md; without it, the examples go to stdout")
    args = parser.parse_args(argv)
    if args.markdown is None:
        sys.stdout.write(markdown(EXAMPLES))
        return 0
    try:
        write_into(args.markdown)
    except OSError as exc:
        parser.error(f"{args.markdown}: {exc.strerror or exc}")
    except ValueError as exc:
        parser.error(str(exc))
    return 0


if __name__ == "__main__":
    sys.exit(main())
