from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
AVCSR = REPO.parent / "shared" / "avcsr" / "kitti"


@pytest.fixture(scope="session")
def avcsr_dir() -> Path:
    if not AVCSR.is_dir():
        pytest.skip(f"the paper's frames are not at {AVCSR}")
    return AVCSR


@pytest.fixture(scope="session")
def reasoner():
    from discern.rules.engine import Reasoner

    return Reasoner()
