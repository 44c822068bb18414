"""A figure of a hand calibration protocol: the box at each rest, in order, as a person sees it on the table
(:mod:`gyrojax.planning.triad_protocol`).

Each box is projected orthographically onto one pair of plain 2-D axes from a fixed eye, 20° above the horizon in
the south-east, and its faces are painted far to near: a convex box needs no depth buffer, so no 3-D axes."""

from __future__ import annotations

import numpy as np

from gyrojax.protocol import atomic_write_bytes

CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float) * [0.6, 0.4, 0.25]
"""The box's corners in the body frame: corner 4x + 2y + z has the signs of its bits (0 for −, 1 for +)."""
FACES = [(0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5)]
"""Corner indices of the faces −x, +x, −y, +y, −z, +z, in order around each."""
FACE_NORMALS = np.array([[-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0], [0, 0, -1], [0, 0, 1]], dtype=float)
PLUS_Z = 5
AXIS_COLOURS = ("tab:red", "tab:green", "tab:blue")
ELEV_DEG, AZIM_DEG = 20.0, -60.0


def view(elev_deg: float = ELEV_DEG, azim_deg: float = AZIM_DEG) -> np.ndarray:
    """(3, 3): rows the screen's right, up and toward-the-eye unit vectors in ENU, for an eye at elevation
    ``elev_deg`` and azimuth ``azim_deg`` (from East, counter-clockwise)."""
    e, a = np.radians(elev_deg), np.radians(azim_deg)
    toward = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    right = np.array([-np.sin(a), np.cos(a), 0.0])
    return np.stack([right, np.cross(toward, right), toward])


def draw_box(ax, c: np.ndarray, v: np.ndarray, at=(0.0, 0.0)) -> None:
    """The box of attitude ``c`` (body → ENU) on 2-D axes ``ax``, seen through ``v`` (:func:`view`) and centred at
    ``at``: faces far to near (+z face blue), then the body axes x, y, z from the centre, each in front of the box
    or behind it as it points toward the eye or away."""
    from matplotlib.patches import Polygon

    o = np.asarray(at, dtype=float)
    pts = CORNERS @ c.T @ v.T  # (8, 3): screen x, y and the distance toward the eye
    depth = np.array([pts[list(f), 2].mean() for f in FACES])
    for rank, k in enumerate(np.argsort(depth)):
        colour = "tab:blue" if k == PLUS_Z else "0.85"
        xy = pts[list(FACES[k]), :2] + o
        ax.add_patch(Polygon(xy, facecolor=colour, edgecolor="k", alpha=0.55, linewidth=0.5, zorder=1 + rank))
    for j, col in enumerate(AXIS_COLOURS):
        e = (c[:, j] * 0.9) @ v.T
        z = 10.0 if e[2] >= 0 else 0.5
        arrow = {"arrowstyle": "-|>", "color": col, "linewidth": 1.5, "shrinkA": 0, "shrinkB": 0}
        ax.annotate("", xy=o + e[:2], xytext=o, arrowprops=arrow, zorder=z)
        ax.text(*(o + e[:2] * 1.15), "xyz"[j], color=col, fontsize=8, ha="center", va="center", zorder=z)


CELL = (2.4, 2.8)
"""Width and height of a box's cell on the figure's one pair of axes (the box's half-diagonal is 0.76)."""


def protocol_figure(proto, path=None, per_row: int = 4):
    """A figure of the box (body axes x red, y green, z blue, +z face shaded) at every rest of ``proto``, ENU axes
    (E right, N into the page, U up), with the step number, face up and the turn that follows; written to ``path``
    as PNG when given. A ``matplotlib.figure.Figure`` made without pyplot: the caller's backend is untouched. The
    boxes share one pair of axes, each in its cell, rows read left to right from the top."""
    import io

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    atts = proto.attitudes()
    rows = proto.table()
    n = len(atts)
    ncol = min(per_row, n)
    nrow = -(-n // ncol)
    fig = Figure(figsize=(3.3 * ncol, 2.9 * nrow))
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0.0, 0.0, 1.0, 0.94))
    v = view()
    w, h = CELL
    for k, (c, r) in enumerate(zip(atts, rows)):
        at = ((k % ncol) * w, -(k // ncol) * h)
        draw_box(ax, np.asarray(c, dtype=float), v, at)
        turn = f"\nthen {r['angle_deg']:.0f}° about {r['turn_axis']}" if "turn_axis" in r else "\n(end)"
        title = f"{r['step']}: {r['up']} up, {r['rest_s']:.0f} s{turn}"
        ax.text(at[0], at[1] + 1.1, title, fontsize=7, ha="center", va="bottom")
    ax.set_xlim(-w / 2, (ncol - 0.5) * w)
    ax.set_ylim(-(nrow - 0.5) * h, h / 2)
    ax.set_aspect("equal")
    ax.set_axis_off()
    fig.suptitle("rests in order (E right, N away, U up; +z face blue)", fontsize=9)
    if path is not None:
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=110)
        atomic_write_bytes(path, buf.getvalue())
    return fig
