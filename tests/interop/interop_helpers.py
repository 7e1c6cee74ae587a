"""Paths and helpers for the interop and reliability tests (issue #6).

The USD corpus lives in the shared folder beside the repository (``../shared/corpus/usd``); set
``RTC_SHARED`` to point elsewhere.  Tests that need it skip when it is absent."""
from __future__ import annotations

import os
import sys
from pathlib import Path


REPO = Path(__file__).resolve().parents[2]
SHARED = Path(os.environ.get('RTC_SHARED', REPO.parent / 'shared'))
USD_CORPUS = SHARED / 'corpus' / 'usd'
COURSE_CORPUS = SHARED / 'corpus' / 'course'
USD_SUFFIXES = ('.usd', '.usda', '.usdc', '.usdz')
RTC = [sys.executable, '-m', 'rtc.cli']          # the real CLI, in a child process


def corpus_files() -> list[str]:
    """Every USD file of the corpus, as paths relative to it (sorted)."""
    if not USD_CORPUS.is_dir():
        return []
    return sorted(str(p.relative_to(USD_CORPUS)) for p in USD_CORPUS.rglob('*')
                  if p.suffix.lower() in USD_SUFFIXES and p.is_file())

