import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
AVCSR = REPO.parent / "shared" / "avcsr" / "kitti"


@pytest.fixture(scope="session")
def avcsr_dir() -> Path:
    if not AVCSR.is_dir():
        message = f"the paper's frames are not at {AVCSR}"
        if os.environ.get("CI"):  # CI has them: a green run must have checked the paper's table
            pytest.fail(message)
        pytest.skip(message)
    return AVCSR


@pytest.fixture(scope="session")
def reasoner():
    from discern.sanity import window_reasoner

    return window_reasoner()
