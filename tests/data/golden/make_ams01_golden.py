"""Snapshot of how the reader read the AMS-01 field records (run once, before issue 15's rewrite).

Usage: ``python tests/data/golden/make_ams01_golden.py`` writes ``ams01_golden.json`` beside
this script: for each of the four AMS-01 files every array's length, SHA-256 of its float64
bytes, sum, min and max (NaN-aware) and 200 evenly spaced sampled values, plus events,
start time, reference, columns and metadata. ``tests/interpret/test_io_ams01.py`` asserts
that the current reader reproduces it. The snapshot was made with the line-by-line reader of
commit b307817 (``src/xlotkit/interpret/io.py``); the 10 MB of arrays themselves are not
stored.
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
AMS = HERE.parents[2] / ".." / "shared" / "data" / "field" / "AMS-01"
FILES = {
    "cu1": "XLOT 1 - Main Claystone_Cementing Unit_Data.txt",
    "dh1": "XLOT 1 - Main Claystone_Downhole Gauge_Data.TXT",
    "cu2": "XLOT 2 - Vlieland Claystone_Cementing Unit_Data.TXT",
    "dh2": "XLOT 2 - Vlieland Claystone_Downhole Gauge_Data.TXT",
}
N_SAMPLES = 200


def summarise(arr: np.ndarray) -> dict:
    a = np.ascontiguousarray(arr, dtype=np.float64)
    idx = np.unique(np.linspace(0, a.size - 1, N_SAMPLES).round().astype(int))
    return {
        "n": int(a.size),
        "sha256": hashlib.sha256(a.tobytes()).hexdigest(),
        "sum": float(np.nansum(a)),
        "min": float(np.nanmin(a)),
        "max": float(np.nanmax(a)),
        "n_nan": int(np.isnan(a).sum()),
        "index": idx.tolist(),
        "values": [float(x) for x in a[idx]],
    }


def snapshot(rec) -> dict:
    arrays = {"t": rec.t, "pressure": rec.pressure}
    for name in ("rate", "volume", "return_rate", "return_volume", "density", "temperature"):
        v = getattr(rec, name)
        if v is not None:
            arrays[name] = v
    for k, v in rec.channels.items():
        arrays["channel:" + k] = v
    return {
        "arrays": {k: summarise(v) for k, v in arrays.items()},
        "start_time": None if rec.start_time is None else rec.start_time.isoformat(),
        "reference": [rec.reference.kind, rec.reference.depth_m, rec.reference.absolute],
        "events": [[e.t, e.text, None if e.timestamp is None else e.timestamp.isoformat(),
                    e.source, e.line] for e in rec.events],
        "columns": [[c.name, c.unit, c.field] for c in rec.columns],
        "meta": json.loads(json.dumps(dict(rec.meta), default=str)),
    }


def main() -> int:
    from xlotkit.interpret.io import read_log

    out = {k: snapshot(read_log(AMS / f)) for k, f in FILES.items()}
    (HERE / "ams01_golden.json").write_text(json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
