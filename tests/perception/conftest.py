"""Fixtures for the perception tests: the synthetic renderer lives in ``perception_synth.py`` beside this file."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
