"""Fixtures for the compiler tests."""
from __future__ import annotations

from pathlib import Path

import pytest

from tests.compiler.compiler_helpers import CORPUS


@pytest.fixture(scope="session")
def course_scenes() -> list[Path]:
    course = CORPUS / "course"
    if not course.is_dir():
        pytest.skip(f"course corpus not found at {course} (shared/ must sit beside the repo, or set RTC_SHARED)")
    return sorted(course.rglob("*.xml"))
