"""Text on a plot that covers neither the curves nor other text.

Every text element a plot adds is queued on a :class:`LabelPlacer` and placed once the
figure's layout is known: pick labels (a value at a point), boxed notes (the leak-off
diagnosis, why a regime was not reached) and legends. What they must keep clear of is read
from the drawn figure in display coordinates, whatever axes it was drawn on (a twin axis
shares the area of its host):

* every line of every axes (data curves, fitted lines, reference lines, ``axvline``
  markers, the pick markers), rasterised along its rendered path with its line width, and
  its markers with their size, clipped to its axes (:func:`obstacle_map`);
* every text already there (titles, axis labels and tick labels, fixed annotations,
  legends) and every element placed before;
* bands (``axvspan``/``axhspan``: intervals and data windows) are shaded areas a text may
  cover, but a spot off them is preferred.

Legends and notes are placed first: a legend at the free spot nearest its preferred corner
inside the axes, a note likewise; when no spot inside is free of lines and text they go
below the axes (under the axis label, stacked), the layout is redone, and the elements
inside are checked again. Then the layout is frozen and each pick label is placed at the
nearest offset around its point (eight directions at growing distances, then anywhere in
the axes with a leader line) whose box is inside the axes and clear of everything above;
a label that had to go far from its point gets a thin leader line to it.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass, field

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.patches import Polygon, Rectangle
from matplotlib.text import Text
from matplotlib.transforms import Bbox, ScaledTranslation

__all__ = ["LabelPlacer", "ObstacleMap", "obstacle_map", "place_labels", "text_boxes"]

_ANGLES = np.deg2rad([45, 135, -45, -135, 90, -90, 0, 180, 22, 158, -22, -158, 68, 112,
                      -68, -112])
_RADII = (10, 16, 24, 34, 46, 60, 78, 100, 125, 160, 200)
#: Clearance kept around a text box [px].
_PAD = 2.0
#: Gap between the axis label and an element placed below the axes [pt].
_BELOW_GAP = 4.0


@dataclass
class _Label:
    ax: object
    x: float
    y: float
    text: str
    color: str
    fontsize: float
    xycoords: object = "data"
    angles: np.ndarray | None = None


@dataclass
class _Note:
    ax: object
    text: str
    fontsize: float
    prefer: str
    color: str
    artist: object = None
    outside: bool = False


@dataclass
class _Legend:
    ax: object
    handles: list
    labels: list
    fontsize: float
    prefer: str
    ncol: int
    title: str | None
    artist: object = None
    outside: bool = False


# ----------------------------------------------------------------------------- obstacles
@dataclass
class ObstacleMap:
    """Where a figure's lines and bands are drawn, as integral images of the figure's pixels.

    Attributes
    ----------
    lines : ndarray, shape (H + 1, W + 1)
        Summed-area table of the pixels a line covers (its width and markers included).
    bands : ndarray, shape (H + 1, W + 1)
        Summed-area table of the pixels a band (span patch) covers.
    """

    lines: np.ndarray
    bands: np.ndarray

    @staticmethod
    def _sums(table: np.ndarray, ext: np.ndarray) -> np.ndarray:
        """Sums of ``table``'s image over boxes ``ext`` (n, 4: x0, y0, x1, y1 px)."""
        h, w = table.shape[0] - 1, table.shape[1] - 1
        ext = np.atleast_2d(np.asarray(ext, float))
        x0 = np.clip(np.floor(ext[:, 0]), 0, w).astype(np.int64)
        y0 = np.clip(np.floor(ext[:, 1]), 0, h).astype(np.int64)
        x1 = np.clip(np.ceil(ext[:, 2]), 0, w).astype(np.int64)
        y1 = np.clip(np.ceil(ext[:, 3]), 0, h).astype(np.int64)
        x1, y1 = np.maximum(x1, x0), np.maximum(y1, y0)
        return (table[y1, x1] - table[y0, x1] - table[y1, x0] + table[y0, x0]).astype(float)

    def line_pixels(self, ext) -> np.ndarray:
        """Number of line pixels under each box of ``ext`` (n, 4, display coordinates)."""
        return self._sums(self.lines, ext)

    def band_fraction(self, ext) -> np.ndarray:
        """Fraction of each box of ``ext`` (n, 4) covered by bands."""
        ext = np.atleast_2d(np.asarray(ext, float))
        area = np.maximum((ext[:, 2] - ext[:, 0]) * (ext[:, 3] - ext[:, 1]), 1.0)
        return np.minimum(self._sums(self.bands, ext) / area, 1.0)


def _mark(mask: np.ndarray, pts: np.ndarray, r: int, clip: Bbox | None) -> None:
    """Set ``mask`` over squares of half-width ``r`` px around display points ``pts``."""
    if pts.size == 0:
        return
    if clip is not None:
        inside = ((pts[:, 0] >= clip.x0 - 0.5) & (pts[:, 0] <= clip.x1 + 0.5)
                  & (pts[:, 1] >= clip.y0 - 0.5) & (pts[:, 1] <= clip.y1 + 0.5))
        pts = pts[inside]
    h, w = mask.shape
    ij = np.round(pts).astype(np.int64)
    ij = np.unique(ij, axis=0)
    off = np.arange(-r, r + 1)
    for dx in off:
        xs = ij[:, 0] + dx
        okx = (xs >= 0) & (xs < w)
        for dy in off:
            ys = ij[:, 1] + dy
            ok = okx & (ys >= 0) & (ys < h)
            mask[ys[ok], xs[ok]] = True


def _sample_segments(xy: np.ndarray) -> np.ndarray:
    """Points at most 0.5 px apart along the polyline ``xy`` (display), gaps at NaN."""
    a, b = xy[:-1], xy[1:]
    ok = np.all(np.isfinite(a), axis=1) & np.all(np.isfinite(b), axis=1)
    a, b = a[ok], b[ok]
    if a.shape[0] == 0:
        return np.zeros((0, 2))
    length = np.hypot(*(b - a).T)
    # Segments far off the figure (a fitted line extended off-scale) are cut by the clip
    # box later; cap the samples so that they cannot blow up memory.
    n = np.clip(np.ceil(2.0 * length).astype(np.int64), 1, 20000)
    seg = np.repeat(np.arange(a.shape[0]), n)
    start = np.repeat(np.cumsum(n) - n, n)
    f = (np.arange(seg.size) - start) / np.repeat(n, n)
    pts = a[seg] + (b[seg] - a[seg]) * f[:, None]
    return np.vstack([pts, b[-1:]])


def _line_display(ln) -> np.ndarray:
    xy = np.asarray(ln.get_xydata(), float)
    if xy.ndim != 2 or xy.shape[0] == 0:
        return np.zeros((0, 2))
    with np.errstate(all="ignore"):
        d = np.asarray(ln.get_transform().transform(xy), float)
    return d


def obstacle_map(fig, renderer) -> ObstacleMap:
    """The :class:`ObstacleMap` of ``fig`` as drawn by ``renderer`` (module docstring)."""
    w = int(np.ceil(fig.bbox.width)) + 1
    h = int(np.ceil(fig.bbox.height)) + 1
    lines = np.zeros((h, w), bool)
    bands = np.zeros((h, w), bool)
    px = fig.dpi / 72.0
    for ax in fig.axes:
        if not ax.get_visible():
            continue
        axbox = ax.get_window_extent(renderer)
        for ln in ax.get_lines():
            if not ln.get_visible():
                continue
            d = _line_display(ln)
            if d.shape[0] == 0:
                continue
            clip = axbox if ln.get_clip_on() else None
            ls = ln.get_linestyle()
            if ls not in ("None", "none", "", " ") and d.shape[0] > 1:
                r = max(1, int(np.ceil(0.5 * ln.get_linewidth() * px)))
                _mark(lines, _sample_segments(d), r, clip)
            mk = ln.get_marker()
            if mk not in (None, "None", "none", "", " "):
                fin = d[np.all(np.isfinite(d), axis=1)]
                r = max(1, int(np.ceil(0.5 * ln.get_markersize() * px
                                       + 0.5 * ln.get_markeredgewidth() * px)))
                _mark(lines, fin, r, clip)
        for p in ax.patches:
            if not p.get_visible() or not isinstance(p, (Rectangle, Polygon)):
                continue
            b = Bbox.intersection(p.get_window_extent(renderer), axbox)
            if b is None:
                continue
            bands[int(max(b.y0, 0)):int(min(b.y1, h)), int(max(b.x0, 0)):int(min(b.x1, w))] \
                = True

    def table(m):
        t = np.zeros((h + 1, w + 1), np.int64)
        t[1:, 1:] = np.cumsum(np.cumsum(m, axis=0), axis=1)
        return t

    return ObstacleMap(table(lines), table(bands))


def _visible_text(t) -> bool:
    return t.get_visible() and bool(t.get_text().strip())


def text_boxes(fig, renderer, exclude=()) -> list[Bbox]:
    """Display boxes of every text on ``fig``: titles, axis labels and tick labels (one
    box per axis), texts and annotations (the text, not a leader line), legends (one box
    each). Artists in ``exclude`` are left out."""
    from matplotlib.axis import Axis
    from matplotlib.legend import Legend

    skip = {id(a) for a in exclude}
    out: list[Bbox] = []

    def visit(artist) -> None:
        if id(artist) in skip or not artist.get_visible():
            return
        if isinstance(artist, Text):
            if _visible_text(artist):
                out.append(Text.get_window_extent(artist, renderer))
        elif isinstance(artist, Legend):
            out.append(artist.get_window_extent(renderer))
        elif isinstance(artist, Axis):
            b = artist.get_tightbbox(renderer)
            if b is not None and b.width > 0 and b.height > 0:
                out.append(b)

    for a in fig.get_children():
        visit(a)
    for ax in fig.axes:
        if ax.get_visible():
            for a in ax.get_children():
                visit(a)
    return out


def _extents(boxes) -> np.ndarray:
    """(n, 4) array of ``Bbox`` extents."""
    return np.array([b.extents for b in boxes], float).reshape(-1, 4)


def _padded(box: Bbox, pad: float) -> Bbox:
    return Bbox.from_extents(box.x0 - pad, box.y0 - pad, box.x1 + pad, box.y1 + pad)


def _overlaps(ext, others: np.ndarray, pad: float = _PAD) -> np.ndarray:
    """Number of boxes of ``others`` (m, 4) within ``pad`` px of each box of ``ext``
    (n, 4)."""
    ext = np.atleast_2d(np.asarray(ext, float))
    if others.shape[0] == 0:
        return np.zeros(ext.shape[0])
    a = ext[:, None, :]
    b = others[None, :, :]
    hit = ((a[..., 0] < b[..., 2] + pad) & (b[..., 0] < a[..., 2] + pad)
           & (a[..., 1] < b[..., 3] + pad) & (b[..., 1] < a[..., 3] + pad))
    return hit.sum(axis=1).astype(float)


# ----------------------------------------------------------------------------- placer
@dataclass
class LabelPlacer:
    """Collects pick labels, notes and legends and places them clear of the figure's lines
    and of each other (module docstring)."""

    labels: list[_Label] = field(default_factory=list)
    notes: list[_Note] = field(default_factory=list)
    legends: list[_Legend] = field(default_factory=list)

    def add(self, ax, x: float, y: float, text: str, color: str = "k",
            fontsize: float = 7.5, marker: bool = True, xycoords="data",
            directions: tuple[float, ...] | None = None) -> None:
        """Mark ``(x, y)`` and queue its label.

        ``xycoords`` is ``"data"`` (data coordinates of ``ax``) or ``("data", "axes
        fraction")`` (x in data, y as a fraction of the axes' height: a mark along its top
        or bottom edge, not marked). ``directions`` [deg] restricts the directions of the
        offsets tried around the point (default: all sixteen)."""
        if not (np.isfinite(x) and np.isfinite(y)):
            return
        if xycoords not in ("data", ("data", "axes fraction")):
            raise ValueError(f"xycoords {xycoords!r}: expected 'data' or "
                             "('data', 'axes fraction')")
        if marker and xycoords == "data":
            ax.plot([x], [y], "o", ms=6, mfc="none", mec=color, mew=1.5, zorder=6)
        ang = None if directions is None else np.deg2rad(np.asarray(directions, float))
        self.labels.append(_Label(ax, float(x), float(y), text, color, fontsize, xycoords,
                                  ang))

    def note(self, ax, text: str, *, fontsize: float = 7.5, prefer: str = "lower left",
             color: str = "k", width: int = 72) -> None:
        """Queue a boxed note on ``ax`` (wrapped at ``width`` characters a line)."""
        lines = []
        for para in text.split("\n"):
            lines.extend(textwrap.wrap(para, width) or [""])
        self.notes.append(_Note(ax, "\n".join(lines), fontsize, prefer, color))

    def legend(self, ax, handles=None, labels=None, *, fontsize: float = 7.5,
               prefer: str = "upper right", ncol: int = 1, title: str | None = None) -> None:
        """Queue the legend of ``ax`` (default: its own handles and labels)."""
        if handles is None:
            handles, labels = ax.get_legend_handles_labels()
        if not handles:
            return
        self.legends.append(_Legend(ax, list(handles), list(labels), fontsize, prefer, ncol,
                                    title))

    def place(self, fig) -> list:
        """Place every queued element; returns the pick-label annotations."""
        return place_labels(fig, self.labels, self.notes, self.legends)


def _renderer(fig):
    """The figure's renderer after its layout has run (drawn without rasterising)."""
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    fig.draw_without_rendering()
    return canvas.get_renderer()


_CORNERS = {"upper right": (1.0, 1.0), "upper left": (0.0, 1.0), "lower left": (0.0, 0.0),
            "lower right": (1.0, 0.0), "upper center": (0.5, 1.0),
            "lower center": (0.5, 0.0), "center left": (0.0, 0.5),
            "center right": (1.0, 0.5), "center": (0.5, 0.5)}


def _spot(axbox: Bbox, size: tuple[float, float], prefer: str, omap: ObstacleMap,
          boxes: list[Bbox]) -> Bbox | None:
    """The free box of ``size`` (w, h px) inside ``axbox`` nearest the ``prefer`` corner:
    no line pixel, no text within the pad; off bands if an equally near spot is."""
    w, h = size
    inset = 4.0
    xs = np.linspace(axbox.x0 + inset, axbox.x1 - inset - w, 25)
    ys = np.linspace(axbox.y0 + inset, axbox.y1 - inset - h, 25)
    if xs[-1] < xs[0] or ys[-1] < ys[0]:
        return None
    fx, fy = _CORNERS.get(prefer, (1.0, 1.0))
    px = axbox.x0 + inset + fx * (axbox.width - 2 * inset - w)
    py = axbox.y0 + inset + fy * (axbox.height - 2 * inset - h)
    X, Y = (a.ravel() for a in np.meshgrid(xs, ys))
    ext = np.column_stack([X, Y, X + w, Y + h])
    free = ((omap.line_pixels(ext + [-_PAD, -_PAD, _PAD, _PAD]) == 0)
            & (_overlaps(ext, _extents(boxes)) == 0))
    if not free.any():
        return None
    cost = (np.hypot(X - px, Y - py) / max(axbox.width, axbox.height)
            + 0.3 * omap.band_fraction(ext))
    cost[~free] = np.inf
    k = int(np.argmin(cost))
    return Bbox.from_bounds(X[k], Y[k], w, h)


def _twins(ax, renderer) -> list:
    """``ax`` and every axes drawn over the same area (``twinx``/``twiny``)."""
    box = ax.get_window_extent(renderer)
    return [o for o in ax.figure.axes
            if np.allclose(o.get_window_extent(renderer).extents, box.extents, atol=0.5)]


def _below_offset(ax, renderer, stacked: float) -> float:
    """Points from the axes' bottom edge to just below the x axes drawn there (tick labels
    and axis label, of ``ax`` or a twin) and everything already stacked there."""
    axbox = ax.get_window_extent(renderer)
    depth = 0.0
    for o in _twins(ax, renderer):
        if o.xaxis.get_visible():
            b = o.xaxis.get_tightbbox(renderer)
            if b is not None:
                depth = max(depth, axbox.y0 - b.y0)
    return depth * 72.0 / ax.figure.dpi + _BELOW_GAP + stacked


def _make_legend(item: _Legend, **kw):
    leg = item.ax.legend(item.handles, item.labels, fontsize=item.fontsize,
                         framealpha=0.9, title=item.title, title_fontsize=item.fontsize,
                         borderaxespad=0.0, **kw)   # (placed at the spot found, exactly)
    leg.set_zorder(8)
    item.artist = leg
    return leg


def _artist_box(it, renderer) -> Bbox:
    art = it.artist
    if isinstance(it, _Legend):
        return art.get_window_extent(renderer)
    return _padded(Text.get_window_extent(art, renderer),
                   0.4 * it.fontsize * it.ax.figure.dpi / 72.0)


def _place_inside(fig, renderer, items, fixed: list[Bbox], omap: ObstacleMap
                  ) -> tuple[list[Bbox], list]:
    """Place notes and legends inside their axes where a free spot exists; returns the
    boxes placed and the items that found none."""
    placed: list[Bbox] = []
    failed = []
    for it in items:
        if it.outside:
            continue
        ax = it.ax
        axbox = ax.get_window_extent(renderer)
        art = it.artist
        size_box = _artist_box(it, renderer)
        spot = _spot(axbox, (size_box.width, size_box.height), it.prefer, omap,
                     fixed + placed)
        if spot is None:
            failed.append(it)
            continue
        fx = (spot.x0 - axbox.x0) / axbox.width
        fy = (spot.y0 - axbox.y0) / axbox.height
        if isinstance(it, _Legend):
            art.set_loc("lower left")
            art.set_bbox_to_anchor((fx, fy), transform=ax.transAxes)
        else:
            pad = 0.4 * it.fontsize * fig.dpi / 72.0
            art.set_position((fx + pad / axbox.width, fy + pad / axbox.height))
        placed.append(spot)
    return placed, failed


def _put_below(fig, renderer, items, stacked: dict) -> None:
    """Move ``items`` below their axes (under the x axis and what is stacked there)."""
    for it in items:
        ax = it.ax
        key = id(_twins(ax, renderer)[0])
        off = _below_offset(ax, renderer, stacked.get(key, 0.0))
        art = it.artist
        tr = ax.transAxes + ScaledTranslation(0.0, -off / 72.0, fig.dpi_scale_trans)
        if isinstance(it, _Legend):
            art.set_loc("upper left")
            art.set_bbox_to_anchor((0.0, 0.0), transform=tr)
            art.set_ncols(max(it.ncol, 2))
            height = art.get_window_extent(renderer).height
        else:
            pad = 0.4 * it.fontsize
            art.set_transform(ax.transAxes + ScaledTranslation(
                pad / 72.0, -(off + pad) / 72.0, fig.dpi_scale_trans))
            art.set_position((0.0, 0.0))
            art.set_va("top")
            height = Text.get_window_extent(art, renderer).height + 2 * pad * fig.dpi / 72
        art.set_in_layout(True)
        it.outside = True
        stacked[key] = stacked.get(key, 0.0) + height * 72.0 / fig.dpi + _BELOW_GAP


def place_labels(fig, labels, notes=(), legends=()) -> list:
    """Place ``legends``, ``notes`` and then ``labels`` on ``fig`` (module docstring)."""
    notes, legends = list(notes), list(legends)
    for lg in legends:
        _make_legend(lg, loc="upper right", ncol=lg.ncol)
    for nt in notes:
        nt.artist = nt.ax.text(0.0, 0.0, nt.text, transform=nt.ax.transAxes,
                               fontsize=nt.fontsize, color=nt.color, ha="left", va="bottom",
                               zorder=8, bbox=dict(boxstyle="round", fc="white", ec="0.6",
                                                   alpha=0.92))
    items = [*legends, *notes]
    renderer = _renderer(fig)
    stacked: dict[int, float] = {}
    for attempt in range(5):
        omap = obstacle_map(fig, renderer)
        # Every text but the elements still to be placed inside (those placed below their
        # axes are obstacles now).
        fixed = text_boxes(fig, renderer,
                           exclude=[it.artist for it in items if not it.outside])
        placed, failed = _place_inside(fig, renderer, items, fixed, omap)
        if not failed:
            break
        if attempt == 4:
            # (not reached in practice: each round moves at least one element below)
            placed = placed + [_artist_box(it, renderer) for it in failed]
            break
        _put_below(fig, renderer, failed, stacked)
        renderer = _renderer(fig)       # the layout makes room below the axes
    fig.set_layout_engine("none")
    if not labels:
        return []
    boxes = fixed + placed
    return [_place_label(fig, renderer, lab, omap, boxes) for lab in labels]


def _label_boxes(anchor, dx, dy, w, h, px, pad=0.0) -> np.ndarray:
    """Display extents (n, 4) of a text of size (w, h) [px] offset (dx, dy) [pt, arrays]
    from ``anchor`` and aligned as :func:`_align` says, grown by ``pad`` [px] (its white
    box)."""
    dx, dy = np.asarray(dx, float), np.asarray(dy, float)
    x = anchor[0] + dx * px
    y = anchor[1] + dy * px
    x0 = np.where(dx > 1, x, np.where(dx < -1, x - w, x - w / 2))
    y0 = np.where(dy > 1, y, np.where(dy < -1, y - h, y - h / 2))
    return np.column_stack([x0 - pad, y0 - pad, x0 + w + pad, y0 + h + pad])


def _align(dx, dy):
    return ("left" if dx > 1 else ("right" if dx < -1 else "center"),
            "bottom" if dy > 1 else ("top" if dy < -1 else "center"))


def _place_label(fig, renderer, lab: _Label, omap: ObstacleMap, boxes: list[Bbox]):
    ax = lab.ax
    px = fig.dpi / 72.0
    probe = ax.annotate(lab.text, (lab.x, lab.y), xycoords=lab.xycoords, xytext=(0, 0),
                        textcoords="offset points", fontsize=lab.fontsize, ha="center",
                        va="center")
    ext = Text.get_window_extent(probe, renderer)
    probe.remove()
    pad = 0.15 * lab.fontsize * px + 1.0          # the label's white box
    w, h = ext.width, ext.height
    tr = ax.transData if lab.xycoords == "data" else ax.get_xaxis_transform()
    anchor = tr.transform((lab.x, lab.y))
    axbox = ax.get_window_extent(renderer)
    others = _extents(boxes)

    def costs(dx, dy):
        e = _label_boxes(anchor, dx, dy, w, h, px, pad)
        inside = ((e[:, 0] >= axbox.x0 + 2) & (e[:, 2] <= axbox.x1 - 2)
                  & (e[:, 1] >= axbox.y0 + 2) & (e[:, 3] <= axbox.y1 - 2))
        hard = (1e6 * _overlaps(e, others) + np.where(inside, 0.0, 1e5)
                + 1e3 * np.minimum(omap.line_pixels(e), 50))
        return hard, hard + 2.0 * omap.band_fraction(e) + 0.02 * np.hypot(dx, dy)

    # Around the point, nearest first: the first radius with a free offset wins.
    R, A = np.meshgrid(np.asarray(_RADII, float),
                       _ANGLES if lab.angles is None else lab.angles, indexing="ij")
    dx, dy = (R * np.cos(A)).ravel(), (R * np.sin(A)).ravel()
    hard, c = costs(dx, dy)
    ok = np.flatnonzero(hard == 0)
    if ok.size:
        ring = R.ravel()[ok[0]]
        cand = ok[R.ravel()[ok] == ring]
        k = int(cand[np.argmin(c[cand])])
    else:
        # Anywhere in the axes, with a leader line: the free spot nearest the point.
        FX, FY = np.meshgrid(np.linspace(0.02, 0.98, 33), np.linspace(0.03, 0.97, 25))
        gx = (axbox.x0 + FX.ravel() * axbox.width - anchor[0]) / px
        gy = (axbox.y0 + FY.ravel() * axbox.height - anchor[1]) / px
        keep = (np.abs(gx) > 1) & (np.abs(gy) > 1)
        dx, dy = np.concatenate([dx, gx[keep]]), np.concatenate([dy, gy[keep]])
        hard, c = costs(dx, dy)
        k = int(np.argmin(c))
    dxk, dyk = float(dx[k]), float(dy[k])
    ha, va = _align(dxk, dyk)
    far = np.hypot(dxk, dyk) > 15
    t = ax.annotate(lab.text, (lab.x, lab.y), xycoords=lab.xycoords, xytext=(dxk, dyk),
                    textcoords="offset points",
                    ha=ha, va=va, fontsize=lab.fontsize, color=lab.color, zorder=9,
                    bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.85),
                    arrowprops=dict(arrowstyle="-", color=lab.color, lw=0.6,
                                    shrinkA=0, shrinkB=4) if far else None)
    t.update_positions(renderer)   # (its extent is read before the next draw)
    e = _label_boxes(anchor, dxk, dyk, w, h, px, pad)[0]
    boxes.append(Bbox.from_extents(*e))
    return t
