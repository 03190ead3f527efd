"""Tests of the studies that live beside their benchmarks in ``benchmarks/`` (not part of the
installed package): the benchmark folder is put on the import path for these tests only."""

from __future__ import annotations

import sys
from pathlib import Path

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"
if str(BENCHMARKS) not in sys.path:
    sys.path.insert(0, str(BENCHMARKS))
