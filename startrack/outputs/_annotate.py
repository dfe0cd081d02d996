"""An annotated PNG of a solved frame for a person to check by eye: the frame stretched so
stars show, identified stars circled and labelled, other spots marked apart, residuals
drawn to scale and a caption with the attitude and field of view."""

from __future__ import annotations

import csv
import functools
import math
from pathlib import Path

import numpy as np

from startrack.io import atomic_path, resource_path
from startrack.outputs._annotate_sky import draw_compass, draw_grid
from startrack.outputs._labels import place_labels
from startrack.outputs._records import frame_record
from startrack.outputs._wcs import solved_wcs_header

#: catalog stars at least this bright get their IAU name beside the HIP number
NAME_MAG_LIMIT = 5.5
_CAPTION_PX = 110  # the caption, the legend and the RA labels under the frame
#: margins around the frame (pixels of the PNG) for the Dec labels and the last label
MARGIN_LEFT_PX = 70
MARGIN_RIGHT_PX = 100  # also holds the compass
MARGIN_TOP_PX = 10
_ARCSEC_PER_RAD = math.degrees(1.0) * 3600.0


def stretch(image: np.ndarray) -> np.ndarray:
    """The frame as 0..1 floats a person can see: background removed, asinh-stretched.

    The background is the median and the noise the median absolute deviation, so the
    sky is dark grey, faint stars show a few noise levels above it and bright stars
    saturate softly instead of everything but them looking black (a 16-bit frame shown
    linearly). Non-finite pixels show as the background.
    """
    img = np.nan_to_num(np.asarray(image, dtype=np.float64), nan=0.0, posinf=0.0, neginf=0.0)
    img = img - _background(img)  # vignetting and sky glow vary across a real frame
    background = float(np.median(img))
    noise = 1.4826 * float(np.median(np.abs(img - background)))
    if noise <= 0:  # a flat or synthetic background: scale by the signal instead
        spread = float(np.percentile(img, 99.9) - background)
        noise = spread / 100.0 if spread > 0 else 1.0
    # Half a noise level above the background is black: the sky is dark with its noise
    # faintly visible, and a star a few noise levels up already shows.
    z = np.clip((img - background) / noise - 0.5, 0.0, None)
    top = max(float(np.percentile(z, 99.95)), 20.0)
    soft = 4.0  # noise levels over which the stretch turns from linear to logarithmic
    return np.clip(np.arcsinh(z / soft) / np.arcsinh(top / soft), 0.0, 1.0)


def _background(img: np.ndarray, block: int = 32) -> np.ndarray:
    """The slowly varying background: medians of block x block tiles, interpolated."""
    import cv2  # cv2: OpenCV, loaded only when a PNG is annotated

    h, w = img.shape
    ny, nx = max(1, h // block), max(1, w // block)
    tiles = img[: ny * block, : nx * block].reshape(ny, block, nx, block)
    medians = np.median(tiles.transpose(0, 2, 1, 3).reshape(ny, nx, -1), axis=2)
    return cv2.resize(medians.astype(np.float32), (w, h), interpolation=cv2.INTER_LINEAR)


@functools.lru_cache(maxsize=1)
def star_names() -> dict[int, str]:
    """IAU (WGSN) star names by HIP number, from data/iau_star_names.csv."""
    path = resource_path("data", "iau_star_names.csv")
    with open(path, newline="", encoding="utf-8") as fh:
        return {int(row["hip"]): row["name"] for row in csv.DictReader(fh)}


def residual_pixels(frame) -> tuple[np.ndarray, np.ndarray]:
    """(dx, dy) in pixels of each identified star: observed minus where the solved
    attitude puts its catalog position (in ``solution.obs_index`` order)."""
    sol = frame.solution
    cam_vectors = sol.rotation.inv().apply(frame.catalog.vectors[sol.cat_index])
    px, py, _ = frame.camera.vector_to_pixel(cam_vectors)
    return frame.obs.x[sol.obs_index] - px, frame.obs.y[sol.obs_index] - py


def _nice_magnification(max_px: float, target_px: float) -> int:
    """A round factor (1, 2, 5, 10, 20, ...) that draws the largest residual near
    ``target_px`` pixels long."""
    if not max_px > 0:
        return 1
    raw = target_px / max_px
    best = 1
    for decade in range(0, 6):
        for step in (1, 2, 5):
            value = step * 10 ** decade
            if value <= raw:
                best = value
    return best


def _labels(frame) -> list[str]:
    cat = frame.catalog
    rows = frame.solution.cat_index
    is_hip = cat.source.get("kind") == "hipparcos"
    names = star_names() if is_hip else {}
    out = []
    for cid, mag in zip(cat.ids[rows], cat.mag[rows], strict=True):
        text = f"HIP {int(cid)}" if is_hip else f"#{int(cid)}"
        name = names.get(int(cid))
        if name and mag <= NAME_MAG_LIMIT:
            text += f" {name}"
        out.append(text)
    return out


def caption(frame) -> str:
    """The caption: input, attitude (RA, Dec, roll), FOV, stars identified, rms residual."""
    record = frame_record(frame)
    fov = record.get("fov_deg", frame.camera.fov_deg)
    head = f"{Path(frame.input).name}   method {frame.solution.method}   FOV {fov:.3f} deg"
    if not frame.solution.solved:
        reason = record.get("reason", "no_match")
        return f"{head}\nnot solved ({reason}): {len(frame.obs)} spots marked"
    att = record["attitude"]
    res = np.asarray(frame.solution.residual_arcsec, dtype=float)
    rms = math.sqrt(float(np.mean(res ** 2))) if len(res) else float("nan")
    return (f"{head}\nRA {att['ra_deg']:.4f} deg   Dec {att['dec_deg']:+.4f} deg   "
            f"roll {att['roll_deg']:.3f} deg   {len(res)} of {len(frame.obs)} spots "
            f"identified   rms residual {rms:.2f} arcsec")


def _draw_labels(ax, frame, x: np.ndarray, y: np.ndarray) -> tuple[list, int]:
    """Label the identified stars at (x, y), brightest first, each where it overlaps no
    other label, circle or edge (:func:`startrack.outputs._labels.place_labels`); returns
    the labels drawn and how many were left out for want of room."""
    texts = _labels(frame)
    order = np.argsort(frame.catalog.mag[frame.solution.cat_index], kind="stable")
    renderer = ax.figure.canvas.get_renderer()
    artists, sizes = [], []
    for k in order:  # measured as drawn: the figure is drawn pixel for pixel (dpi 100)
        text = ax.text(0.0, 0.0, texts[k], color="#b8ffb0", fontsize=7, zorder=5,
                       ha="left", va="top")
        extent = text.get_window_extent(renderer)
        artists.append(text)
        sizes.append((extent.width, extent.height))
    h = frame.camera.height
    boxes = place_labels(x[order], y[order], sizes, frame.camera.width, h)
    drawn = []
    for text, box in zip(artists, boxes, strict=True):
        if box is None:
            text.remove()
        else:
            text.set_position((box[0] - 0.5, box[1] - 0.5))  # pixel centres at integers
            drawn.append(text)
    return drawn, len(artists) - len(drawn)


def _draw_stars(ax, frame, width: int) -> tuple:
    """Mark the spots and label the identified stars; returns the residual scale (factor,
    bar length drawn in px, what it stands for in px and arcsec; None when nothing is
    identified), the labels drawn and how many were left out.

    The other spots are small and faint underneath; the identified stars are drawn on
    top, so a frame of several hundred spots still shows which ones were identified.
    """
    sol = frame.solution
    obs = frame.obs
    ident = np.zeros(len(obs), dtype=bool)
    if sol.solved:
        ident[sol.obs_index] = True
    ax.scatter(obs.x[~ident], obs.y[~ident], s=22, marker="s", facecolors="none",
               edgecolors="#ff9f1c", linewidths=0.6, alpha=0.45, zorder=2,
               label="not identified")
    if not sol.solved:
        return None, [], 0
    x, y = obs.x[sol.obs_index], obs.y[sol.obs_index]
    ax.scatter(x, y, s=170, marker="o", facecolors="none", edgecolors="#39ff14",
               linewidths=1.2, zorder=4, label="identified")
    labels, left_out = _draw_labels(ax, frame, x, y)
    dx, dy = residual_pixels(frame)
    mag = _nice_magnification(float(np.hypot(dx, dy).max(initial=0.0)), 0.04 * width)
    ax.quiver(x, y, dx * mag, dy * mag, angles="xy", scale_units="xy", scale=1.0,
              color="#ff3864", width=0.0025, zorder=5, label="residual")
    arcsec_per_px = _ARCSEC_PER_RAD / frame.camera.f_px
    bar_px = 0.04 * width
    bar_as = bar_px / mag * arcsec_per_px
    return (mag, bar_px, bar_px / mag, bar_as), labels, left_out


def _draw_caption(fig, frame, scale: tuple | None, width: int, left_out: int) -> None:
    """The caption band under the frame: the text, the residual scale bar, the legend."""
    import matplotlib.lines  # matplotlib: only when a PNG is annotated

    fig_w, fig_h = fig.bbox.width, fig.bbox.height
    band = _CAPTION_PX / fig_h
    right = (MARGIN_LEFT_PX + width) / fig_w
    text = caption(frame)
    if scale is not None:
        mag, bar_px, stands_px, stands_as = scale
        text += (f"\nresiduals (observed - catalog) drawn x{mag}: the bar = {stands_px:.2g} "
                 f"px = {stands_as:.2g} arcsec")
        if left_out:
            text += f"; {left_out} crowded label(s) left out (--corr lists every star)"
        y_bar = 0.12 * band
        fig.add_artist(matplotlib.lines.Line2D(
            [right - bar_px / fig_w, right], [y_bar, y_bar], color="#ff3864", linewidth=2))
    fig.legend(loc="upper right", bbox_to_anchor=(right, 0.62 * band), fontsize=7, ncol=3,
               facecolor="black", edgecolor="grey", labelcolor="white", framealpha=0.6)
    fig.text(MARGIN_LEFT_PX / fig_w, 0.3 * band, text, color="white", fontsize=8,
             va="center", family="monospace")


def write_annotated(frame, path: str | Path) -> dict:
    """Write the annotated PNG of one :class:`~startrack.solver._identifier.FrameResult`;
    returns ``{"labels": [(x0, y0, x1, y1), ...], "left_out": n}``: each star label's box
    as drawn (PNG pixels, y up) and the labels left out for want of room.

    The frame is drawn pixel for pixel inside margins that hold the RA/Dec labels; a
    solved frame gets an RA/Dec grid and a north/east compass from its solved WCS
    (:func:`startrack.outputs._wcs.solved_wcs_header`). A centroid-list input (no image) is drawn
    on a black frame of the camera's size.
    """
    import matplotlib  # matplotlib: only when a PNG is annotated

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # matplotlib: after its backend is chosen

    w, h = frame.camera.width, frame.camera.height
    shown = stretch(frame.image) if frame.image is not None else np.zeros((h, w))
    dpi = 100
    fig_w, fig_h = w + MARGIN_LEFT_PX + MARGIN_RIGHT_PX, h + MARGIN_TOP_PX + _CAPTION_PX
    fig = plt.figure(figsize=(fig_w / dpi, fig_h / dpi), dpi=dpi, facecolor="black")
    rect = (MARGIN_LEFT_PX / fig_w, _CAPTION_PX / fig_h, w / fig_w, h / fig_h)
    wcs = None
    if frame.solution.solved:
        from astropy.wcs import WCS  # astropy: only for a solved frame's grid

        wcs = WCS(solved_wcs_header(frame))
        ax = fig.add_axes(rect, projection=wcs)
    else:
        ax = fig.add_axes(rect)
        ax.set_axis_off()
    ax.set_facecolor("black")
    ax.imshow(shown, cmap="gray", vmin=0.0, vmax=1.0, interpolation="nearest",
              extent=(-0.5, w - 0.5, -0.5, h - 0.5), origin="lower")  # row i at y = i
    scale, labels, left_out = _draw_stars(ax, frame, w)
    ax.set_xlim(-0.5, w - 0.5)
    ax.set_ylim(h - 0.5, -0.5)  # row 0 at the top, as in the PNG
    if wcs is not None:
        draw_grid(ax, wcs, w, h)
        # in the right margin, beside the frame, so it hides no star
        draw_compass(fig, wcs, w, h, centre=(MARGIN_LEFT_PX + w + 0.5 * MARGIN_RIGHT_PX,
                                             _CAPTION_PX + h - 0.5 * MARGIN_RIGHT_PX),
                     length_px=0.35 * MARGIN_RIGHT_PX)
    _draw_caption(fig, frame, scale, w, left_out)
    path = Path(path)
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=dpi, format="png", facecolor="black")
        boxes = [tuple(t.get_window_extent().extents) for t in labels]
    finally:
        plt.close(fig)
    return {"labels": boxes, "left_out": left_out}
