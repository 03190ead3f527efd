"""The plots an engineer reads: labels clear of each other and inside the axes, legends in
words, the interval band and the window drawn, the report PDF written."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.text import Text

from xlotkit.interpret.calibration.records import ConstructedSpec, construct_record, dfit_record
from xlotkit.interpret.diagnostics import diagnose_record
from xlotkit.interpret.picks.core import pick_record
from xlotkit.interpret.plots.labels import LabelPlacer
from xlotkit.interpret.plots.picks import pick_figures

#: Internal names that must never reach a legend or a label.
INTERNAL = ("line_after", "line_open", "line_closed", "flowback_sqrt_p", "flowback_p_v",
            "g_function", "sqrt_t", "_range", "fitted line")


@pytest.fixture(scope="module")
def figures():
    cr = construct_record(ConstructedSpec(transition=0.02, noise=0.05e5,
                                          flowback=(True, False)))
    rp = pick_record(cr.record, cr.segmentation)
    figs = pick_figures(rp)
    rec, seg, _ = dfit_record(pre="pressure_dependent_leakoff", after="exponential",
                              duration=6.0, tau=800.0)
    rp2 = pick_record(rec, seg)
    figs.update({f"dfit_{k}": f for k, f in pick_figures(rp2, diagnose_record(rp2)).items()})
    return figs


def _texts(fig):
    for ax in fig.axes:
        leg = ax.get_legend()
        if leg is not None:
            yield from (t.get_text() for t in leg.get_texts())
        yield from (t.get_text() for t in ax.texts)


def test_legends_and_labels_are_in_words(figures):
    for name, fig in figures.items():
        for text in _texts(fig):
            for bad in INTERNAL:
                assert bad not in text, (name, text)


def test_pick_labels_never_overlap_each_other_and_stay_in_the_axes(figures):
    for name, fig in figures.items():
        canvas = FigureCanvasAgg(fig)
        canvas.draw()
        r = canvas.get_renderer()
        for ax in fig.axes:
            # The text itself (an annotation's extent includes its leader line).
            boxes = [Text.get_window_extent(t, r) for t in ax.texts
                     if t.get_text().startswith(("FCP", "ISIP", "LOP", "FBP", "reopening",
                                                 "FPP", "closure", "reservoir"))]
            axbox = ax.get_window_extent(r)
            for i, b in enumerate(boxes):
                assert axbox.x0 - 1 <= b.x0 and b.x1 <= axbox.x1 + 1, name
                for b2 in boxes[i + 1:]:
                    assert not b.overlaps(b2), (name, ax.get_title())


def test_labels_avoid_the_curve():
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6, 4))
    ax = fig.subplots()
    x = np.linspace(0, 10, 2000)
    ax.plot(x, np.sin(x), ".", ms=1)
    pl = LabelPlacer()
    for xi in (2.0, 2.2, 2.4, 5.0):
        pl.add(ax, xi, float(np.sin(xi)), f"pick at {xi:.1f}: a long label", "k")
    arts = pl.place(fig)
    r = fig.canvas.get_renderer()
    pts = ax.transData.transform(np.column_stack([x, np.sin(x)]))
    for a in arts:
        b = Text.get_window_extent(a, r)
        inside = ((pts[:, 0] > b.x0) & (pts[:, 0] < b.x1) & (pts[:, 1] > b.y0)
                  & (pts[:, 1] < b.y1))
        assert not inside.any()
    for i, a in enumerate(arts):
        for a2 in arts[i + 1:]:
            assert not Text.get_window_extent(a, r).overlaps(Text.get_window_extent(a2, r))


def test_diagnostic_plots_show_the_interval_band_and_the_window(figures):
    import matplotlib.patches as mp

    for key in ("cycle1_flowback_p_v", "cycle2_g_function", "cycle2_sqrt_t",
                "dfit_cycle1_after_closure"):
        fig = figures[key]
        labels = [t for t in _texts(fig)]
        assert any("90 % interval" in t for t in labels), (key, labels)
        assert any(isinstance(p, mp.Rectangle) or isinstance(p, mp.Polygon)
                   for ax in fig.axes for p in ax.patches), key
    g = [t for t in _texts(figures["cycle2_g_function"])]
    assert any("data window used" in t for t in g)
    assert any("leak-off diagnosis" in t for t in g)
    ll = [t for t in _texts(figures["dfit_cycle1_loglog"])]
    assert {"½", "¼", "¾", "0", "1"} <= set(ll)
