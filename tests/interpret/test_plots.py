"""The plots an engineer reads: every text (pick labels, notes, legends) clear of every
drawn line on every axes and of every other text, labels inside the axes, legends in words,
the interval band and the window drawn, the report PDF written."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.text import Text
from plot_geometry import collisions, segment_hits

from xlotkit.interpret.calibration.records import ConstructedSpec, construct_record, dfit_record
from xlotkit.interpret.diagnostics import diagnose_record
from xlotkit.interpret.picks.core import pick_record
from xlotkit.interpret.plots.labels import LabelPlacer
from xlotkit.interpret.plots.picks import pick_figures

#: The AMS-01 field records, in the project's shared data next to the checkout (or a
#: worktree of it).
FIELD = next((d / "shared" / "data" / "field" / "AMS-01" for d in Path(__file__).parents
              if (d / "shared" / "data" / "field" / "AMS-01").is_dir()), Path("missing"))

#: Internal names that must never reach a legend or a label.
INTERNAL = ("line_after", "line_open", "line_closed", "flowback_sqrt_p", "flowback_p_v",
            "g_function", "sqrt_t", "_range", "fitted line", "m G_c", "m·G")


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
    rec, seg, _ = dfit_record(pre="normal", after="radial", duration=30.0, dt=5.0,
                              noise=0.02e5)
    rp3 = pick_record(rec, seg)
    figs.update({f"radial_{k}": f for k, f in pick_figures(rp3, diagnose_record(rp3)).items()})
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


def test_segment_box_intersection_of_the_geometry_check():
    # The checker itself, against hand-made cases: through, inside, beside, corner-cut.
    box = (0.0, 0.0, 10.0, 5.0)
    p0 = np.array([[-5.0, 2.0], [2.0, 1.0], [-5.0, 7.0], [-1.0, 4.0], [11.0, -1.0]])
    p1 = np.array([[15.0, 2.0], [3.0, 2.0], [15.0, 6.0], [2.0, 7.0], [12.0, 9.0]])
    assert segment_hits(box, p0, p1).tolist() == [True, True, False, True, False]


def test_no_text_over_a_line_or_another_text(figures):
    """Every figure (G-function and square-root-of-time with a twin axis, p-t overview,
    p-V, flowback, bilinear, log-log, after-closure): no pick label, note, legend or fixed
    text meets a rendered line segment or marker of any axes, or another text (exact
    segment-box intersection of the drawn geometry, renderer boxes)."""
    bad = {name: collisions(fig) for name, fig in figures.items()}
    assert not any(bad.values()), {k: v for k, v in bad.items() if v}


@pytest.mark.skipif(not FIELD.is_dir(), reason="AMS-01 field data not available")
def test_no_text_over_a_line_on_the_field_record():
    """AMS-01 XLOT 1 (surface + downhole merged): the figures where the audit found text
    struck through (the leak-off diagnosis over G dP/dG, dP/dG and the line through the
    origin; the G-function pick's label on G dP/dG; a pick label on the derivative of the
    square-root plot; legends over the right-axis curve) are clean."""
    from xlotkit.interpret.io import read_logs
    from xlotkit.pipeline import interpret_record

    it = interpret_record(read_logs([str(f) for f in sorted(FIELD.glob("XLOT 1*"))]))
    figs = pick_figures(it.picks, it.diagnostics)
    keys = [k for k in figs if k == "overview" or k.endswith(
        ("_g_function", "_sqrt_t", "_flowback_p_v", "_flowback_sqrt_p"))]
    assert "cycle1_g_function" in keys
    bad = {k: collisions(figs[k]) for k in keys}
    assert not any(bad.values()), {k: v for k, v in bad.items() if v}


def test_a_note_with_no_room_inside_goes_below_the_axes():
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6, 4), layout="constrained")
    ax = fig.subplots()
    x = np.linspace(0, 10, 400)
    for k in range(40):     # lines everywhere: no free spot inside for the note
        ax.plot(x, np.sin(x + 0.3 * k) + 0.1 * k, lw=0.8)
    ax.set_xlabel("time [s]")
    pl = LabelPlacer()
    pl.note(ax, "a long note that has nowhere to go inside the axes, so it goes below")
    pl.legend(ax, [ax.get_lines()[0]], ["one curve"])
    pl.place(fig)
    r = fig.canvas.get_renderer()
    axbox = ax.get_window_extent(r)
    note = next(t for t in ax.texts if t.get_text().startswith("a long note"))
    b = Text.get_window_extent(note, r)
    assert b.y1 < axbox.y0 and b.y1 < ax.xaxis.get_tightbbox(r).y0
    assert b.y0 >= 0
    # The small legend finds the strip the autoscale margin leaves free, or goes below too.
    assert collisions(fig) == []


def test_every_diagnostic_plot_marks_its_window_as_a_band(figures):
    """The log-log and after-closure plots (exponential and radial regime) shade the data
    window of the after-closure fit; the after-closure plots draw the reservoir pressure's
    interval as a band."""
    for key in ("dfit_cycle1_loglog", "dfit_cycle1_after_closure", "radial_cycle1_loglog",
                "radial_cycle1_after_closure"):
        fig = figures[key]
        ax = fig.axes[0]
        spans = [p.get_label() for p in ax.patches]
        assert any(lab.startswith("data window used") for lab in spans), (key, spans)
        if key.endswith("after_closure"):
            assert any("reservoir pressure 90 % interval" in lab for lab in spans), key
