"""Where each star's label goes on an annotated frame: beside its star, clear of every
label already placed, of every star's circle and of the frame's edges. Labels are placed
in the order given (the brightest star first); one with no free place is left out
rather than drawn over another (the record, --corr and the WCS list every star)."""

from __future__ import annotations

import numpy as np

#: the radius of an identified star's circle, image pixels (a 170 pt^2 marker at 100 dpi)
CIRCLE_RADIUS_PX = 9.0
#: the space between a circle's edge and its label, image pixels
GAP_PX = 2.0
#: space kept between two labels, image pixels
PAD_PX = 1.0


def _candidates(sx: float, sy: float, w: float, h: float) -> list[tuple[float, float]]:
    """Top-left corners (x, y; y down) of the places tried for a w x h label of the star
    at (sx, sy): right, left, above, below, then the four diagonals."""
    g = CIRCLE_RADIUS_PX + GAP_PX
    d = 0.7 * g
    return [(sx + g, sy - h / 2), (sx - g - w, sy - h / 2), (sx - w / 2, sy - g - h),
            (sx - w / 2, sy + g), (sx + d, sy - d - h), (sx + d, sy + d),
            (sx - d - w, sy - d - h), (sx - d - w, sy + d)]


def _hits_circle(box: tuple, cx: np.ndarray, cy: np.ndarray) -> bool:
    """Whether the box (x0, y0, x1, y1) covers part of any circle centred at (cx, cy)."""
    x0, y0, x1, y1 = box
    nx = np.clip(cx, x0, x1) - cx
    ny = np.clip(cy, y0, y1) - cy
    return bool(np.any(nx * nx + ny * ny < CIRCLE_RADIUS_PX ** 2))


def _overlaps(box: tuple, placed: list[tuple]) -> bool:
    x0, y0, x1, y1 = box
    return any(x0 < b[2] + PAD_PX and b[0] < x1 + PAD_PX and y0 < b[3] + PAD_PX
               and b[1] < y1 + PAD_PX for b in placed)


def place_labels(x, y, sizes, width: int, height: int) -> list[tuple | None]:
    """Each label's box (x0, y0, x1, y1), image pixels with y down, or None when it has
    no free place. ``x``, ``y``: the stars (every one a circle to keep clear); ``sizes``:
    each label's (width, height) in pixels, in the order the labels are placed."""
    cx, cy = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    placed: list[tuple] = []
    boxes: list[tuple | None] = []
    for sx, sy, (w, h) in zip(cx, cy, sizes, strict=True):
        chosen = None
        for left, top in _candidates(sx, sy, w, h):
            box = (left, top, left + w, top + h)
            if (left < 0 or top < 0 or box[2] > width or box[3] > height
                    or _overlaps(box, placed) or _hits_circle(box, cx, cy)):
                continue
            chosen = box
            break
        if chosen is not None:
            placed.append(chosen)
        boxes.append(chosen)
    return boxes


__all__ = ["CIRCLE_RADIUS_PX", "GAP_PX", "PAD_PX", "place_labels"]
