"""A figure of a hand calibration protocol: the box at each rest, in order, as a person sees it on the table
(:mod:`gyrojax.planning.triad_protocol`)."""

from __future__ import annotations

import numpy as np

from gyrojax.protocol import atomic_write_bytes

CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float) * [0.6, 0.4, 0.25]
FACES = [(0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5)]


def protocol_figure(proto, path=None, per_row: int = 4):
    """A figure of the box (body axes x red, y green, z blue, +z face shaded) at every rest of ``proto``, ENU axes
    (E right, N into the page, U up), with the step number, face up and the turn that follows; written to ``path``
    as PNG when given. A ``matplotlib.figure.Figure`` made without pyplot: the caller's backend is untouched."""
    import io

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # registers the 3d projection

    atts = proto.attitudes()
    rows = proto.table()
    n = len(atts)
    ncol = min(per_row, n)
    nrow = -(-n // ncol)
    fig = Figure(figsize=(3.3 * ncol, 2.9 * nrow))
    FigureCanvasAgg(fig)
    for k, (c, r) in enumerate(zip(atts, rows)):
        ax = fig.add_subplot(nrow, ncol, k + 1, projection="3d")
        pts = CORNERS @ c.T
        polys = [[pts[i] for i in f] for f in FACES]
        colors = ["0.85"] * 6
        colors[1] = "tab:blue"  # the +z face
        ax.add_collection3d(Poly3DCollection(polys, facecolors=colors, edgecolors="k", alpha=0.55, linewidths=0.5))
        for j, col in enumerate(("tab:red", "tab:green", "tab:blue")):
            e = c[:, j] * 0.9
            ax.quiver(0, 0, 0, *e, color=col, linewidth=1.5, arrow_length_ratio=0.2)
            ax.text(*(e * 1.15), "xyz"[j], color=col, fontsize=8)
        ax.set_xlim(-0.8, 0.8)
        ax.set_ylim(-0.8, 0.8)
        ax.set_zlim(-0.8, 0.8)
        ax.set_axis_off()
        ax.view_init(elev=20, azim=-60)
        turn = f"\nthen {r['angle_deg']:.0f}° about {r['turn_axis']}" if "turn_axis" in r else "\n(end)"
        ax.set_title(f"{r['step']}: {r['up']} up, {r['rest_s']:.0f} s{turn}", fontsize=7)
    fig.suptitle("rests in order (E right, N away, U up; +z face blue)", fontsize=9)
    if path is not None:
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=110)
        atomic_write_bytes(path, buf.getvalue())
    return fig
