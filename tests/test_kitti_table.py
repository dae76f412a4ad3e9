from discern.adapters.avcsr import read_dir
from discern.scenarios import paper_table


def test_all_24_paper_frames_agree_with_expected_action(avcsr_dir, reasoner):
    rows = paper_table.run(read_dir(avcsr_dir), reasoner, repeats=1)
    assert len(rows) == 24
    disagreements = [(r.frame.scenario, r.frame.frame, r.decision) for r in rows if not r.agrees]
    assert disagreements == []


def test_table_groups_frames_by_the_papers_four_environments(avcsr_dir, reasoner):
    rows = paper_table.run(read_dir(avcsr_dir), reasoner, repeats=1)
    table = paper_table.format_table(rows)
    for env, (avg, worst) in paper_table.PAPER_MS.items():
        line = next(l for l in table.splitlines() if l.startswith(env))
        assert " 6/6 " in line and str(avg) in line and str(worst) in line
    assert "24/24" in table


def test_misstamped_fact_is_read_by_its_timestamp_and_reported(avcsr_dir):
    frames = {(f.scenario, f.frame): f for f in read_dir(avcsr_dir)}
    frame2 = frames[("2011_09_26_drive_0029", 2)]
    assert any("stamped T=1 but sits under FRAME 2" in n for n in frames[("2011_09_26_drive_0029", 1)].notes)
    assert any("no current lanes given" in n for n in frame2.notes)
    assert frame2.scene.current_lanes() == [1]
