"""Fixtures for the interop and reliability tests (issue #6)."""
from __future__ import annotations

import pytest

from tests.interop.interop_helpers import USD_CORPUS


@pytest.fixture(scope='session')
def usd_corpus() -> Path:
    if not USD_CORPUS.is_dir():
        pytest.skip(f'USD corpus not found at {USD_CORPUS}')
    return USD_CORPUS
