"""`discern demo`: the main job in one command, on embedded defaults."""

from __future__ import annotations

import argparse
from pathlib import Path

from discern.rules.engine import Reasoner
from discern.scenarios import paper_table, runner

REPO = Path(__file__).resolve().parents[1]
KITTI = REPO.parent / "shared" / "avcsr" / "kitti"
SCENARIOS = Path(runner.__file__).resolve().parent


def banner(title: str) -> None:
    print(f"\n=== {title} " + "=" * max(0, 70 - len(title)))


def paper(reasoner: Reasoner, kitti: Path) -> bool:
    banner("1. The AUTO-DISCERN paper's KITTI frames")
    if not kitti.is_dir():
        print(f"skipped: the paper's frames are not at {kitti} (pass --kitti DIR)")
        return True
    rows = paper_table.run(kitti, reasoner, repeats=5)
    print(paper_table.format_rows(rows))
    print()
    print(paper_table.format_table(rows))
    return all(r.agrees for r in rows)


def verdict(reasoner: Reasoner) -> None:
    banner("2. A verdict with its justification (KITTI 0051, merge left in heavy traffic)")
    scenario = runner.load(SCENARIOS / "paper" / "kitti_merge_left_heavy_traffic.json")
    frame = scenario.frames[0]
    print(f"the planner proposes: {frame.proposed.value}\n")
    print(reasoner.decide(frame.scene, frame.proposed).justification.text)


def cmd_demo(args: argparse.Namespace) -> int:
    reasoner = Reasoner()
    ok = paper(reasoner, Path(args.kitti))
    verdict(reasoner)
    return 0 if ok else 1


def register(sub) -> None:
    demo = sub.add_parser("demo", help="run the main job: paper table, a verdict, the sidecar, the closed loop")
    demo.add_argument("--kitti", default=str(KITTI), help="directory of the paper's AV-CSR frame files")
    demo.add_argument("--out", default="out", help="directory for logs, reports and plots")
    demo.set_defaults(func=cmd_demo)
