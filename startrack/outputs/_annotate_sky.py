"""The sky on an annotated frame: an RA/Dec grid (astropy WCSAxes) and a north/east
compass, both from the frame's solved WCS (:func:`startrack.outputs._wcs.solved_wcs_header`)."""

from __future__ import annotations

import math

import numpy as np


def compass(wcs, x0: float, y0: float, length_px: float) -> dict[str, np.ndarray]:
    """Pixel offsets (dx, dy) of arrows ``length_px`` long pointing north and east at
    pixel (x0, y0), from the solved WCS (pixels 0-based, row 0 at the top).

    Returns
    -------
    dict
        ``{"N": array([dx, dy]), "E": array([dx, dy])}``.
    """
    ra, dec = wcs.all_pix2world([x0], [y0], 0)
    step = 0.01 * abs(float(np.degrees(length_px / _focal_px(wcs))))  # a short step, deg
    cos_dec = max(math.cos(math.radians(float(dec[0]))), 1e-6)
    targets = {"N": (ra[0], dec[0] + step), "E": (ra[0] + step / cos_dec, dec[0])}
    arrows = {}
    for name, (r, d) in targets.items():
        px, py = wcs.all_world2pix([r], [d], 0)
        v = np.array([px[0] - x0, py[0] - y0])
        arrows[name] = v / np.hypot(*v) * length_px
    return arrows


def _focal_px(wcs) -> float:
    """Pixels per radian at the reference point (from the CD matrix)."""
    scale_deg = math.sqrt(abs(np.linalg.det(wcs.pixel_scale_matrix)))
    return 1.0 / math.radians(scale_deg)


def draw_compass(fig, wcs, width: int, height: int, centre: tuple[float, float],
                 length_px: float) -> None:
    """North and east arrows, as they point at the frame's centre, drawn from ``centre``
    (figure pixels, y up) ``length_px`` long."""
    x0, y0 = centre
    for name, (dx, dy) in compass(wcs, 0.5 * (width - 1), 0.5 * (height - 1),
                                  length_px).items():
        tip = (x0 + dx, y0 - dy)  # image rows run down, figure pixels up
        fig.add_artist(_arrow("", tip, (x0, y0)))
        fig.text((x0 + 1.35 * dx) / fig.bbox.width, (y0 - 1.35 * dy) / fig.bbox.height,
                 name, color="#ffe066", fontsize=10, ha="center", va="center",
                 weight="bold")


def _arrow(text: str, tip: tuple, tail: tuple):
    """An arrow from ``tail`` to ``tip`` in figure pixels."""
    from matplotlib.text import Annotation  # matplotlib: only when a PNG is annotated

    return Annotation(text, xy=tip, xytext=tail, xycoords="figure pixels",
                      textcoords="figure pixels",
                      arrowprops=dict(arrowstyle="-|>", color="#ffe066", lw=1.6))


#: grid steps tried, the finest first: RA in seconds of time, Dec in arcsec
RA_STEPS_S = (1, 2, 5, 10, 15, 20, 30, 60, 120, 300, 600, 900, 1200, 1800, 3600, 7200,
              10800, 14400, 21600)
DEC_STEPS_AS = (1, 2, 5, 10, 15, 20, 30, 60, 120, 300, 600, 900, 1200, 1800, 3600, 7200,
                10800, 18000, 36000, 54000, 108000)
#: grid lines wanted across the edge that carries a coordinate's labels
GRID_LABELS = 4


def _edge_span_deg(wcs, x: np.ndarray, y: np.ndarray, axis: int) -> float:
    """How far RA (``axis`` 0, unwrapped across 0h) or Dec (1) runs along pixels x, y."""
    values = np.asarray(wcs.all_pix2world(x, y, 0)[axis], dtype=float)
    if axis == 0:
        values = np.degrees(np.unwrap(np.radians(values)))
    return float(values.max() - values.min())


def grid_steps(wcs, width: int, height: int) -> tuple[float, float]:
    """The RA step (seconds of time) and Dec step (arcsec) that put at least
    :data:`GRID_LABELS` lines across the bottom edge (RA labels) and the left edge (Dec
    labels), the coarsest such round steps."""
    xs, ys = np.linspace(0, width - 1, 64), np.linspace(0, height - 1, 64)
    ra_span_s = _edge_span_deg(wcs, xs, np.full(64, height - 1.0), 0) * 240.0
    dec_span_as = _edge_span_deg(wcs, np.zeros(64), ys, 1) * 3600.0
    ra = [s for s in RA_STEPS_S if ra_span_s / s >= GRID_LABELS]
    dec = [s for s in DEC_STEPS_AS if dec_span_as / s >= GRID_LABELS]
    return float(ra[-1] if ra else RA_STEPS_S[0]), float(dec[-1] if dec else DEC_STEPS_AS[0])


def draw_grid(ax, wcs, width: int, height: int) -> None:
    """RA/Dec grid lines and their labels (WCSAxes), faint so the stars stay in front:
    round steps with at least :data:`GRID_LABELS` lines across each labelled edge."""
    import astropy.units as u  # astropy: only when a PNG is annotated

    ra_step, dec_step = grid_steps(wcs, width, height)
    ra, dec = ax.coords[0], ax.coords[1]
    ra.set_major_formatter("hh:mm" if ra_step % 60 == 0 else "hh:mm:ss")
    dec.set_major_formatter("dd" if dec_step % 3600 == 0 else
                            "dd:mm" if dec_step % 60 == 0 else "dd:mm:ss")
    ra.set_ticks(spacing=ra_step * 15.0 * u.arcsec, color="#9fc5e8")
    dec.set_ticks(spacing=dec_step * u.arcsec, color="#9fc5e8")
    for coord, label in ((ra, "RA (ICRS)"), (dec, "Dec (ICRS)")):
        coord.grid(color="#6fa8dc", alpha=0.7, linestyle="dashed", linewidth=0.7)
        coord.set_ticklabel(color="#9fc5e8", size=8)
        coord.set_axislabel(label, color="#9fc5e8", size=8)
    ra.set_ticks_position("b")
    ra.set_ticklabel_position("b")
    ra.set_axislabel_position("b")
    dec.set_ticks_position("l")
    dec.set_ticklabel_position("l")
    dec.set_axislabel_position("l")
