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


def draw_grid(ax) -> None:
    """RA/Dec grid lines and their labels (WCSAxes), faint so the stars stay in front."""
    ra, dec = ax.coords[0], ax.coords[1]
    ra.set_major_formatter("hh:mm")
    dec.set_major_formatter("dd:mm")
    for coord, label in ((ra, "RA (ICRS)"), (dec, "Dec (ICRS)")):
        coord.grid(color="#6fa8dc", alpha=0.7, linestyle="dashed", linewidth=0.7)
        coord.set_ticklabel(color="#9fc5e8", size=8)
        coord.set_ticks(color="#9fc5e8", number=6)
        coord.set_axislabel(label, color="#9fc5e8", size=8)
    ra.set_ticks_position("b")
    ra.set_ticklabel_position("b")
    ra.set_axislabel_position("b")
    dec.set_ticks_position("l")
    dec.set_ticklabel_position("l")
    dec.set_axislabel_position("l")
