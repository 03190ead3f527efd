"""Pick labels that overlap neither each other nor the curves.

Labels are collected first (:class:`LabelPlacer`) and placed once the figure's layout is
fixed: for each label, offsets around its point are tried, nearest first (eight
directions at growing distances), and the first whose text box lies inside the axes, clear
of every label placed before and of every plotted data point and of the legends and boxed notes, wins. A label that had to go
far from its point gets a thin leader line to it. The figure's layout engine is switched
off afterwards so that saving does not move the axes under the placed labels.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.transforms import Bbox

__all__ = ["LabelPlacer", "place_labels"]

_ANGLES = np.deg2rad([45, 135, -45, -135, 90, -90, 0, 180, 22, 158, -22, -158, 68, 112,
                      -68, -112])
_RADII = (10, 20, 34, 50, 70, 95, 125, 160, 200)


@dataclass
class _Label:
    ax: object
    x: float
    y: float
    text: str
    color: str
    fontsize: float


@dataclass
class LabelPlacer:
    """Collects labels of points and places them without overlaps (module docstring)."""

    labels: list[_Label] = field(default_factory=list)

    def add(self, ax, x: float, y: float, text: str, color: str = "k",
            fontsize: float = 7.5, marker: bool = True) -> None:
        """Mark ``(x, y)`` (data coordinates of ``ax``) and queue its label."""
        if not (np.isfinite(x) and np.isfinite(y)):
            return
        if marker:
            ax.plot([x], [y], "o", ms=6, mfc="none", mec=color, mew=1.5, zorder=6)
        self.labels.append(_Label(ax, float(x), float(y), text, color, fontsize))

    def place(self, fig) -> list:
        """Place every queued label; returns the annotation artists."""
        return place_labels(fig, self.labels)


def _points(ax) -> np.ndarray:
    """Display coordinates of every data point plotted on ``ax`` (subsampled)."""
    pts = []
    for ln in ax.get_lines():
        xy = np.asarray(ln.get_xydata(), float)
        if xy.ndim != 2 or xy.shape[0] == 0:
            continue
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        if xy.shape[0] > 4000:
            xy = xy[:: xy.shape[0] // 4000 + 1]
        try:
            pts.append(ln.get_transform().transform(xy))
        except (ValueError, TypeError):
            continue
    return np.concatenate(pts) if pts else np.zeros((0, 2))


def _hits(box: Bbox, pts: np.ndarray, pad: float = 2.0) -> int:
    if pts.size == 0:
        return 0
    return int(np.sum((pts[:, 0] >= box.x0 - pad) & (pts[:, 0] <= box.x1 + pad)
                      & (pts[:, 1] >= box.y0 - pad) & (pts[:, 1] <= box.y1 + pad)))


def place_labels(fig, labels) -> list:
    """Place ``labels`` on ``fig`` (see the module docstring)."""
    if not labels:
        return []
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    fig.set_layout_engine("none")
    placed: dict[int, list[Bbox]] = {}
    pts_of: dict[int, np.ndarray] = {}
    out = []
    for lab in labels:
        ax = lab.ax
        key = id(ax)
        if key not in pts_of:
            pts_of[key] = _points(ax)
            # Legends and text boxes already on the axes (and on twin axes sharing its
            # area) are obstacles too.
            placed[key] = []
            for other in fig.axes:
                if other.get_window_extent(renderer).overlaps(ax.get_window_extent(renderer)):
                    leg = other.get_legend()
                    if leg is not None:
                        placed[key].append(leg.get_window_extent(renderer))
                    for txt in other.texts:
                        if txt.get_bbox_patch() is not None:
                            placed[key].append(txt.get_window_extent(renderer))
        axbox = ax.get_window_extent(renderer)
        best = None
        for r in _RADII:
            for a in _ANGLES:
                dx, dy = r * np.cos(a), r * np.sin(a)
                ha = "left" if dx > 1 else ("right" if dx < -1 else "center")
                va = "bottom" if dy > 1 else ("top" if dy < -1 else "center")
                t = ax.annotate(lab.text, (lab.x, lab.y), xytext=(dx, dy),
                                textcoords="offset points", ha=ha, va=va,
                                fontsize=lab.fontsize, color=lab.color, zorder=7)
                box = t.get_window_extent(renderer)
                inside = (box.x0 >= axbox.x0 + 2 and box.x1 <= axbox.x1 - 2
                          and box.y0 >= axbox.y0 + 2 and box.y1 <= axbox.y1 - 2)
                overlap = sum(box.overlaps(b) for b in placed[key])
                hits = _hits(box, pts_of[key])
                # Never on another label, then never outside the axes, then as few data
                # points under it as possible, then as close as possible.
                cost = 1e5 * overlap + (0 if inside else 1e4) + 10 * hits + 0.01 * r
                t.remove()
                if best is None or cost < best[0]:
                    best = (cost, dx, dy, ha, va)
                if inside and overlap == 0 and hits == 0:
                    break
            if best is not None and best[0] < 1.0:
                break
        _, dx, dy, ha, va = best
        far = np.hypot(dx, dy) > 15
        t = ax.annotate(lab.text, (lab.x, lab.y), xytext=(dx, dy), textcoords="offset points",
                        ha=ha, va=va, fontsize=lab.fontsize, color=lab.color, zorder=7,
                        bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none",
                                  alpha=0.8),
                        arrowprops=dict(arrowstyle="-", color=lab.color, lw=0.6,
                                        shrinkA=0, shrinkB=4) if far else None)
        placed[key].append(t.get_window_extent(renderer))
        out.append(t)
    return out
