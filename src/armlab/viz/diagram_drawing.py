"""Drawing a :class:`~armlab.viz.loop_diagram.LoopDiagram` with matplotlib (no other
dependency): the forward path left to right on one row, the blocks that feed a block from
above (a second reference, the disturbance, the environment) over it, and the measured
signals on lanes under the row, from the sensors back to every block that reads them (a dot
where a lane branches).  Sizes are measured from the text itself, so a block is as wide as
its widest line and nothing is cut.  Lengths below are inches.
"""

from __future__ import annotations

from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Circle, FancyBboxPatch

from armlab.viz.loop_diagram import Block, LoopDiagram, loop_diagram

TITLE_SIZE, DETAIL_SIZE, LABEL_SIZE = 8.0, 7.0, 7.0  # [pt]
PAD = 0.07                # text to box edge
SUM_RADIUS = 0.13
GAP = 0.42                # least arrow length between blocks
ABOVE_GAP = 0.42          # from a block's top to the block over it
LANE_FIRST, LANE_STEP = 0.38, 0.30  # the first lane under the row, and between lanes
MARGIN = 0.15
FILL = {"reference": "#eef3fb", "law": "#fff7e6", "hold": "#f3f3f3", "saturation": "#fdecea",
        "plant": "#e9f5ec", "environment": "#f5ecdf", "disturbance": "#f3f3f3", "sensors": "#eef3fb"}
EDGE = "#2b3440"
LANE_COLOURS = ("#1f5fd6", "#2a9d5b", "#8e44ad", "#c0392b", "#b9770e")


class _Measure:
    """Text extents [in] on the figure's own renderer."""

    def __init__(self, fig: Figure):
        self.fig = fig
        self.renderer = fig.canvas.get_renderer()

    def size(self, text: str, fontsize: float, weight: str = "normal") -> tuple[float, float]:
        if not text:
            return 0.0, 0.0
        artist = self.fig.text(0, 0, text, fontsize=fontsize, weight=weight, linespacing=1.25)
        box = artist.get_window_extent(self.renderer)
        artist.remove()
        return box.width / self.fig.dpi, box.height / self.fig.dpi


class _Placed:
    """A block with its measured size and its centre."""

    def __init__(self, block: Block, measure: _Measure):
        self.block = block
        head, _, rest = block.title.partition("\n")
        self.head, self.rest = head, rest
        self.details = "\n".join(block.lines)
        self.x = self.y = 0.0
        if block.kind == "sum":
            self.width = self.height = 2 * SUM_RADIUS
            self.sizes = []
            return
        sizes = [measure.size(head, TITLE_SIZE, "bold"), measure.size(rest, TITLE_SIZE),
                 measure.size(self.details, DETAIL_SIZE)]
        self.sizes = sizes
        glyph = 0.32 if block.kind == "saturation" else 0.0
        self.width = max(w for w, _ in sizes) + 2 * PAD + glyph
        self.height = sum(h for _, h in sizes) + 2 * PAD + 0.04 * sum(1 for _, h in sizes if h)

    @property
    def left(self) -> float:
        return self.x - self.width / 2

    @property
    def right(self) -> float:
        return self.x + self.width / 2

    @property
    def top(self) -> float:
        return self.y + self.height / 2

    @property
    def bottom(self) -> float:
        return self.y - self.height / 2


def _layout(diagram: LoopDiagram, measure: _Measure):
    """Centres of the row's blocks and of the blocks above them; returns (row, above, width)."""
    row = [_Placed(block, measure) for block in diagram.blocks]
    above = {i: _Placed(p.block.above, measure) for i, p in enumerate(row) if p.block.above is not None}
    x = MARGIN
    previous_above_right = -1e9
    for i, placed in enumerate(row):
        label = measure.size(diagram.blocks[i - 1].output, LABEL_SIZE)[0] if i else 0.0
        x += (max(GAP, label + 0.16) if i else 0.0)
        slot = placed.width
        if i in above:
            slot = max(slot, above[i].width)
        centre = x + slot / 2
        if i in above and centre - above[i].width / 2 < previous_above_right + 0.2:
            centre = previous_above_right + 0.2 + above[i].width / 2
        placed.x = centre
        # The next block starts after this one's slot: a wider block above it takes the room.
        x = centre + slot / 2
        if i in above:
            above[i].x = centre
            previous_above_right = centre + above[i].width / 2
    for i, placed in above.items():
        placed.y = row[i].top + ABOVE_GAP + placed.height / 2
    return row, above, x + MARGIN


def _box(ax, placed: _Placed) -> None:
    block = placed.block
    if block.kind == "sum":
        ax.add_patch(Circle((placed.x, placed.y), SUM_RADIUS, fc="white", ec=EDGE, lw=1.0))
        ax.text(placed.x, placed.y, "Σ", ha="center", va="center", fontsize=TITLE_SIZE)
        return
    ax.add_patch(FancyBboxPatch((placed.left, placed.bottom), placed.width, placed.height,
                                boxstyle="round,pad=0,rounding_size=0.05", fc=FILL.get(block.kind, "white"),
                                ec=EDGE, lw=1.0))
    left = placed.left + PAD
    if block.kind == "saturation":
        # The saturation's characteristic, drawn: linear between ±τ_max, flat beyond.
        gx, gy, s = placed.left + 0.18, placed.y, 0.1
        ax.plot([gx - s, gx - s / 2, gx + s / 2, gx + s], [gy - s / 2, gy - s / 2, gy + s / 2, gy + s / 2],
                color=EDGE, lw=1.1)
        left += 0.32
    y = placed.top - PAD
    for (text, size, weight, colour), (_, height) in zip(
            ((placed.head, TITLE_SIZE, "bold", EDGE), (placed.rest, TITLE_SIZE, "normal", EDGE),
             (placed.details, DETAIL_SIZE, "normal", "#4a5560")), placed.sizes, strict=True):
        if text:
            ax.text(left, y, text, ha="left", va="top", fontsize=size, weight=weight, color=colour,
                    linespacing=1.25)
            y -= height + 0.04


def _arrow(ax, start, end, colour=EDGE, lw=1.0) -> None:
    ax.annotate("", xy=end, xytext=start, arrowprops=dict(arrowstyle="-|>", color=colour, lw=lw,
                                                          shrinkA=0, shrinkB=0, mutation_scale=9))


def _edge_x(placed: _Placed, dy: float) -> float:
    """Where a horizontal arrow at height dy above the centre meets the block's left edge."""
    if placed.block.kind == "sum":
        return placed.x - (max(SUM_RADIUS**2 - dy**2, 0.0)) ** 0.5
    return placed.left


def _lanes(ax, diagram: LoopDiagram, row: list[_Placed], half: float) -> float:
    """The measured signals from the sensors back to their readers; returns the lowest y."""
    sensors = row[-1]
    signals = diagram.signals
    readers = {s: [p for p in row if s in p.block.reads] for s in signals}
    bottom = -half
    drops = [sensors.left + (k + 1) * sensors.width / (len(signals) + 1) for k in range(len(signals))]
    for k, signal in enumerate(signals):
        y = -half - LANE_FIRST - k * LANE_STEP
        bottom = y
        colour = LANE_COLOURS[k % len(LANE_COLOURS)]
        users = readers[signal]
        if not users:
            continue
        # Each reader takes the lanes it reads side by side along its lower edge.
        entries = []
        for placed in users:
            mine = [s for s in signals if s in placed.block.reads]
            spread = min(0.16, placed.width / (len(mine) + 1))
            offset = (mine.index(signal) - (len(mine) - 1) / 2) * spread
            entries.append((placed, placed.x + offset))
        leftmost = min(x for _, x in entries)
        ax.plot([drops[k], drops[k], leftmost], [sensors.bottom, y, y], color=colour, lw=1.0)
        for placed, x in entries:
            edge = placed.bottom if placed.block.kind != "sum" else placed.y - SUM_RADIUS * 0.97
            _arrow(ax, (x, y), (x, edge), colour)
            if x != leftmost:
                ax.plot([x], [y], "o", color=colour, ms=3)
            if placed.block.kind == "sum":
                ax.text(x + 0.03, edge - 0.03, "−", ha="left", va="top", fontsize=LABEL_SIZE, color=colour)
        ax.text(drops[k] - 0.05, y + 0.02, signal, ha="right", va="bottom", fontsize=LABEL_SIZE, color=colour)
    return bottom


def draw_loop_diagram(diagram: LoopDiagram, *, dpi: int = 100) -> Figure:
    """A matplotlib Figure of ``diagram`` (not registered with pyplot: nothing to close)."""
    fig = Figure(dpi=dpi)
    FigureCanvasAgg(fig)
    measure = _Measure(fig)
    row, above, width = _layout(diagram, measure)
    half = max(p.height for p in row) / 2
    top = max([half] + [p.top for p in above.values()]) + 0.38
    lowest = -half - LANE_FIRST - max(len(diagram.signals) - 1, 0) * LANE_STEP - MARGIN - 0.08
    fig.set_size_inches(width, top - lowest)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_xlim(0, width)
    ax.set_ylim(lowest, top)
    ax.axis("off")
    ax.text(MARGIN, top - 0.08, diagram.title, ha="left", va="top", fontsize=TITLE_SIZE + 1, weight="bold")
    for placed in row:
        _box(ax, placed)
    for first, second in zip(row, row[1:], strict=False):
        start = first.right if first.block.kind != "sum" else first.x + SUM_RADIUS
        _arrow(ax, (start, 0.0), (_edge_x(second, 0.0), 0.0))
        if first.block.output:
            ax.text((start + _edge_x(second, 0.0)) / 2, 0.04, first.block.output, ha="center", va="bottom",
                    fontsize=LABEL_SIZE)
    for i, placed in above.items():
        _box(ax, placed)
        target = row[i]
        block = target.block
        entry = target.top if block.kind != "sum" else target.y + SUM_RADIUS
        if block.exchange:
            # The environment reads the pose and returns the wrench: one arrow each way.
            _arrow(ax, (target.x - 0.12, entry), (target.x - 0.12, placed.bottom))
            _arrow(ax, (target.x + 0.12, placed.bottom), (target.x + 0.12, entry))
            ax.text(target.x - 0.16, (entry + placed.bottom) / 2, block.exchange, ha="right", va="center",
                    fontsize=LABEL_SIZE)
            ax.text(target.x + 0.16, (entry + placed.bottom) / 2, block.above_label, ha="left", va="center",
                    fontsize=LABEL_SIZE)
        else:
            _arrow(ax, (target.x, placed.bottom), (target.x, entry))
            ax.text(target.x + 0.05, (entry + placed.bottom) / 2, block.above_label, ha="left", va="center",
                    fontsize=LABEL_SIZE)
    _lanes(ax, diagram, row, half)
    return fig


DIAGRAM_DPI = 100  # the report shows the PNG at its own size: 7 pt text stays legible


def diagram_png(scenario, *, dpi: int = DIAGRAM_DPI) -> bytes:
    """The PNG of ``scenario``'s closed-loop block diagram (:func:`loop_diagram`)."""
    from armlab.viz.html import figure_png

    return figure_png(draw_loop_diagram(loop_diagram(scenario), dpi=dpi), dpi=dpi)


def write_diagram(scenario, path) -> Path:
    """Write ``scenario``'s block diagram as the PNG ``path``; returns the path."""
    from armlab.files import write_bytes

    return write_bytes(Path(path), diagram_png(scenario))
