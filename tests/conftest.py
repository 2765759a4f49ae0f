from __future__ import annotations

import sys
from pathlib import Path

# tests/ holds shared helpers (fixture_ws, uros_helpers) imported by both suites.
sys.path.insert(0, str(Path(__file__).parent))
