"""Pick.details is typed per method family, and its mapping keeps the report's key names.

Before issue 16 the details were free-form dicts; :meth:`Details.to_dict` must give the same
keys (the ones listed here are those the old code wrote), so a report written from them is
unchanged in content.
"""

from __future__ import annotations

import json

from test_picks_shutin import decline

from xlotkit.interpret.picks.core import pick_cycle
from xlotkit.interpret.picks.details import (
    ConsensusDetails,
    Details,
    IsipDetails,
    RejectedDetails,
    SlopeBreakDetails,
    TangentDetails,
)
from xlotkit.interpret.picks.shutin import SHUTIN_METHODS
from xlotkit.interpret.report import _jsonable

BAR = 1e5


def test_every_pick_of_a_cycle_has_typed_details_that_serialise():
    rec, cyc = decline(noise=0.02 * BAR)
    cp = pick_cycle(rec, cyc)
    for p in (*cp.picks, cp.fcp):
        assert p.details is None or isinstance(p.details, Details), (p.name, p.method)
        if p.details is not None:
            json.dumps(_jsonable(p.details))      # plain JSON, no NaN left over
    assert isinstance(cp.get("ISIP").details, IsipDetails)
    assert isinstance(cp.fcp.details, ConsensusDetails)
    assert isinstance(cp.get("FCP", "tangent").details, TangentDetails)


def test_the_mapping_keeps_the_historical_keys():
    rec, cyc = decline(noise=0.02 * BAR)
    g = SHUTIN_METHODS["g_function"](rec, cyc)
    assert isinstance(g.details, SlopeBreakDetails) and g.details.x_name == "G"
    d = g.details.to_dict()
    for key in ("slope", "slope_stderr", "intercept", "G_range", "G_pick", "G_pick_stderr",
                "slope_after", "closure_signature", "slope_ratio", "break_score", "r2", "n",
                "trial_values", "breakpoint_stderr", "sampling_resolution", "interval",
                "isip", "t_shut_in", "t_pump", "drop_samples_skipped", "diagnosis", "alpha"):
        assert key in d, key
    assert set(d["line_after"]) == {"slope", "intercept", "G_range"}
    assert d["G_pick"] == g.details.x_pick and d["slope"] == g.details.line_before.slope
    t = SHUTIN_METHODS["tangent"](rec, cyc).details.to_dict()
    for key in ("early_slope", "late_slope", "early_window", "late_window", "r2_early",
                "r2_late", "t_intersection", "pressure_on_curve"):
        assert key in t, key
    rej = RejectedDetails(original=g.details, rejected_value=1.0, rejected_low=0.5,
                          rejected_high=1.5, reason="x")
    r = rej.to_dict()
    assert r["rejected_value"] == 1.0 and r["G_pick"] == d["G_pick"]
