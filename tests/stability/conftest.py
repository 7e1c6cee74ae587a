"""Shared helpers: the hand-built scenes of tests/renderer/handmade.py."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'renderer'))
