"""Pick reports: JSON schema, CSV table, plots, and never destroying earlier results."""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from xlotkit.interpret.phases import Segmentation
from xlotkit.interpret.picks.core import FCP_METHODS, PickOptions, pick_record
from xlotkit.interpret.report import picks_table, picks_to_dict, write_pick_report

BAR = 1e5


def _load_fb():
    path = Path(__file__).with_name("test_picks_flowback.py")
    spec = importlib.util.spec_from_file_location("_xlot_fb_helpers_rep", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


fb = _load_fb()


@pytest.fixture(scope="module")
def record_picks():
    t, p, v, _ = fb.choke_flowback()
    rng = np.random.default_rng(3)
    rec, cyc = fb.make_record(t, p + rng.normal(0, 0.05 * BAR, p.size), v,
                              reference="downhole")
    rec = rec.replace(sources=("well_A.csv",))
    return pick_record(rec, Segmentation(cyc.phases, (cyc,), True))


CYCLE_KEYS = {"index", "kind", "reference", "fbp_bar", "reopening_bar", "fpp_bar", "isip_bar",
              "lop_bar", "fcp_bar", "fcp_low_bar", "fcp_high_bar", "stiffness_bar_per_m3",
              "methods"}


def test_json_schema_keys_nulls_and_values(record_picks):
    d = picks_to_dict(record_picks)
    assert {"sources", "reference", "cycles", "stress"} <= set(d)
    assert d["sources"] == ["well_A.csv"] and d["stress"] is None
    assert "downhole" in d["reference"]
    (c,) = d["cycles"]
    assert CYCLE_KEYS <= set(c)
    assert c["index"] == 1 and c["kind"] == "xlot" and "downhole" in c["reference"]
    # The synthetic pump-in has no reopening (first cycle) -> null, not NaN or missing.
    assert c["reopening_bar"] is None
    assert set(c["methods"]) == set(FCP_METHODS)
    for m in c["methods"].values():
        assert set(m) == {"fcp_bar", "low_bar", "high_bar", "level", "quality", "message"}
    truth = (100 * BAR + fb.RHO_G_H) / BAR
    assert c["fcp_bar"] == pytest.approx(truth, rel=5e-3)
    assert c["fcp_low_bar"] <= c["fcp_bar"] <= c["fcp_high_bar"]
    assert c["methods"]["flowback_sqrt_p"]["fcp_bar"] == pytest.approx(truth, rel=5e-3)
    assert c["stiffness_bar_per_m3"] == pytest.approx(60.0, rel=0.02)
    # Strict JSON: no NaN anywhere.
    json.dumps(d, allow_nan=False)


def test_json_methods_not_run_are_null():
    t, p, v, _ = fb.choke_flowback()
    rec, cyc = fb.make_record(t, p, v)
    rp = pick_record(rec, Segmentation(cyc.phases, (cyc,), True),
                     options=PickOptions(methods=("flowback_sqrt_p",)))
    c = picks_to_dict(rp)["cycles"][0]
    assert c["methods"]["flowback_p_v"] == {"fcp_bar": None, "low_bar": None,
                                            "high_bar": None, "level": None,
                                            "quality": "none", "message": "not run"}


def test_stress_objects_are_serialised(record_picks):
    from dataclasses import dataclass

    @dataclass(frozen=True)
    class S:
        sigma_h: float
        arr: np.ndarray

    d = picks_to_dict(record_picks, stress=S(1.5e7, np.array([1.0, np.nan])))
    assert d["stress"] == {"sigma_h": 1.5e7, "arr": [1.0, None]}
    assert picks_to_dict(record_picks, stress={"a": 1})["stress"] == {"a": 1}


def test_table_rows(record_picks):
    df = picks_table(record_picks)
    assert isinstance(df, pd.DataFrame)
    n_picks = len(record_picks.cycles[0].picks)
    assert len(df) == n_picks + 1  # + consensus
    row = df[(df.method == "flowback_p_v")].iloc[0]
    assert row["value_bar"] == pytest.approx((100 * BAR + fb.RHO_G_H) / BAR, rel=5e-3)
    assert row["t_min"] == pytest.approx(row["t_s"] / 60)
    assert (df["method"] == "consensus").sum() == 1


def test_write_report_files_and_never_overwrite(record_picks, tmp_path):
    out = tmp_path / "report"
    paths = write_pick_report(record_picks, out)
    assert paths["dir"] == out
    assert paths["csv"].exists() and paths["json"].exists()
    csv = pd.read_csv(paths["csv"])
    assert {"cycle", "name", "method", "value_bar"} <= set(csv.columns)
    data = json.loads(paths["json"].read_text())
    assert data["cycles"][0]["index"] == 1
    pngs = {k for k in paths if k not in ("dir", "csv", "json")}
    assert {"overview", "cycle1_flowback_sqrt_p", "cycle1_flowback_p_v", "cycle1_p_v"} <= pngs
    for k in pngs:
        assert paths[k].read_bytes()[:4] == b"\x89PNG"
    # No temporary files left behind.
    assert not [f for f in out.iterdir() if f.name.startswith(".")]
    before = {f.name: f.read_bytes() for f in out.iterdir()}

    # A second report goes to a fresh sibling; the first is untouched.
    paths2 = write_pick_report(record_picks, out, plots=False)
    assert paths2["dir"] == tmp_path / "report-2"
    assert paths2["json"].exists()
    assert {f.name: f.read_bytes() for f in out.iterdir()} == before
    paths3 = write_pick_report(record_picks, out, plots=False)
    assert paths3["dir"] == tmp_path / "report-3"

    # Or refuse outright.
    with pytest.raises(FileExistsError):
        write_pick_report(record_picks, out, plots=False, if_exists="error")
    assert {f.name: f.read_bytes() for f in out.iterdir()} == before


def test_write_into_existing_folder_without_report(record_picks, tmp_path):
    out = tmp_path / "x"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    paths = write_pick_report(record_picks, out, plots=False)
    assert paths["dir"] == out and (out / "notes.txt").read_text() == "keep me"


def test_values_are_finite_or_null(record_picks):
    d = picks_to_dict(record_picks)

    def walk(x):
        if isinstance(x, float):
            assert math.isfinite(x)
        elif isinstance(x, dict):
            for v in x.values():
                walk(v)
        elif isinstance(x, list):
            for v in x:
                walk(v)

    walk(d)
