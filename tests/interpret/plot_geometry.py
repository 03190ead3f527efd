"""Exact geometry of a drawn figure, for the tests of text placement: the display
segments of every line (as the Agg renderer draws them, clipped to their axes) and the
boxes of every text, legend and axis; and the collisions between them.

Independent of :mod:`xlotkit.interpret.plots.labels` (which works on a raster of the
figure): here every segment is intersected exactly with every box (Liang-Barsky)."""

from __future__ import annotations

import numpy as np
from matplotlib.axis import Axis
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.legend import Legend
from matplotlib.text import Text


def segment_hits(box, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
    """Whether each segment ``p0[i] -> p1[i]`` (display) meets the box ``(x0, y0, x1,
    y1)`` (Liang-Barsky clipping)."""
    x0, y0, x1, y1 = box
    d = p1 - p0
    t0 = np.zeros(p0.shape[0])
    t1 = np.ones(p0.shape[0])
    ok = np.ones(p0.shape[0], bool)
    for p, q in ((-d[:, 0], p0[:, 0] - x0), (d[:, 0], x1 - p0[:, 0]),
                 (-d[:, 1], p0[:, 1] - y0), (d[:, 1], y1 - p0[:, 1])):
        par = np.abs(p) < 1e-12
        ok &= ~(par & (q < 0))
        with np.errstate(divide="ignore", invalid="ignore"):
            r = q / p
        t0 = np.where(~par & (p < 0), np.maximum(t0, r), t0)
        t1 = np.where(~par & (p > 0), np.minimum(t1, r), t1)
    return ok & (t0 <= t1)


def line_geometry(ax, renderer):
    """``(name, segments (n, 2, 2), points (m, 2))`` of every visible line of ``ax``, in
    display coordinates, clipped to the axes box where the line is clipped."""
    axbox = ax.get_window_extent(renderer)
    out = []
    for ln in ax.get_lines():
        if not ln.get_visible():
            continue
        path = ln.get_transform().transform_path(ln.get_path())
        v = np.asarray(path.vertices, float)
        segs = np.zeros((0, 2, 2))
        if ln.get_linestyle() not in ("None", "none", "", " ") and v.shape[0] > 1:
            segs = np.stack([v[:-1], v[1:]], axis=1)
            segs = segs[np.all(np.isfinite(segs), axis=(1, 2))]
        pts = np.zeros((0, 2))
        if ln.get_marker() not in (None, "None", "none", "", " "):
            pts = v[np.all(np.isfinite(v), axis=1)]
        if ln.get_clip_on():
            inside = ((pts[:, 0] >= axbox.x0) & (pts[:, 0] <= axbox.x1)
                      & (pts[:, 1] >= axbox.y0) & (pts[:, 1] <= axbox.y1))
            pts = pts[inside]
        out.append((ln.get_label(), segs, pts, ln.get_clip_on(), axbox))
    return out


def text_geometry(fig, renderer):
    """``(what, box extents)`` of every text on the figure: texts and annotations (the
    text, not a leader line), legends (whole box), titles, axes' tick labels and labels
    (one box per axis)."""
    out = []

    def visit(a, owner):
        if not a.get_visible():
            return
        if isinstance(a, Legend):
            out.append((f"legend of {owner}", a.get_window_extent(renderer).extents))
        elif isinstance(a, Text):
            if a.get_text().strip():
                out.append((a.get_text()[:40], Text.get_window_extent(a, renderer).extents))
        elif isinstance(a, Axis):
            b = a.get_tightbbox(renderer)
            if b is not None and b.width > 0 and b.height > 0:
                out.append((f"{a.axis_name}-axis of {owner}", b.extents))

    for a in fig.get_children():
        visit(a, "figure")
    for ax in fig.axes:
        for a in ax.get_children():
            visit(a, ax.get_title() or "axes")
    return out


def _is_axis(what: str) -> bool:
    return what.startswith(("x-axis of ", "y-axis of "))


def collisions(fig, text_only=None):
    """Every text box that meets a line segment or marker, or another text box.

    Parameters
    ----------
    fig : Figure
    text_only : callable, optional
        ``text_only(what) -> bool``: restrict the texts checked against lines.

    Returns
    -------
    list of str
        One line per collision (empty when the figure is clean).
    """
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    canvas.draw()
    r = canvas.get_renderer()
    texts = text_geometry(fig, r)
    lines = [g for ax in fig.axes for g in line_geometry(ax, r)]
    bad = []
    for what, (x0, y0, x1, y1) in texts:
        if _is_axis(what):
            continue      # tick labels sit outside the axes, ticks on the spines
        if text_only is not None and not text_only(what):
            continue
        for name, segs, pts, clipped, axbox in lines:
            bx = (x0, y0, x1, y1)
            if clipped:
                bx = (max(x0, axbox.x0), max(y0, axbox.y0), min(x1, axbox.x1),
                      min(y1, axbox.y1))
                if bx[0] >= bx[2] or bx[1] >= bx[3]:
                    continue
            if segs.shape[0] and segment_hits(bx, segs[:, 0], segs[:, 1]).any():
                bad.append(f"text {what!r} crosses line {name!r}")
            elif pts.shape[0] and np.any((pts[:, 0] >= bx[0]) & (pts[:, 0] <= bx[2])
                                         & (pts[:, 1] >= bx[1]) & (pts[:, 1] <= bx[3])):
                bad.append(f"text {what!r} covers points of {name!r}")
    for i, (w1, b1) in enumerate(texts):
        for w2, b2 in texts[i + 1:]:
            if _is_axis(w1) and _is_axis(w2):
                continue  # the x and y axes of an axes meet at its corners
            if b1[0] < b2[2] and b2[0] < b1[2] and b1[1] < b2[3] and b2[1] < b1[3]:
                bad.append(f"text {w1!r} overlaps text {w2!r}")
    return bad
