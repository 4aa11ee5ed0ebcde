"""Shared fixtures: paths to the real recordings beside the project, and small factories."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"


def shared_path(*parts: str) -> Path:
    """A path under ../shared/data, skipping the test with a reason when it is absent."""
    path = SHARED_DATA.joinpath(*parts)
    if not path.exists():
        pytest.skip(
            f"real recordings not present at {path} (they sit beside the project in CI; "
            "see ../shared/data/README.md)"
        )
    return path


@pytest.fixture
def shared_data() -> Path:
    return shared_path()
