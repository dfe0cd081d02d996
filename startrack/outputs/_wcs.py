"""The solved world coordinate system of a frame as a FITS header: TAN, SIP terms when the
camera has lens distortion, and the frame's date, camera and software.

Pixel convention (docs/conventions.md): our pixel (x, y) is FITS pixel (x + 1, y + 1), so
``astropy.wcs.WCS(header).all_pix2world(x, y, 0)`` takes our pixels as they are.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from astropy.io import fits
from astropy.wcs import WCS
from scipy.spatial.transform import Rotation

from startrack import __version__
from startrack.camera import Camera
from startrack.io import atomic_path, date_obs_of
from startrack.sky import vectors_to_radec


@dataclass(frozen=True)
class SipTerms:
    """SIP polynomial coefficients (FITS ``A_p_q``, ``B_p_q``, ``AP_p_q``, ``BP_p_q``):
    ``a[p, q]`` is the coefficient of ``u**p * v**q``, u and v the pixel offsets from
    CRPIX. A and B map observed (distorted) pixels to ideal ones; AP and BP back."""

    order: int
    a: np.ndarray
    b: np.ndarray
    ap: np.ndarray | None = None
    bp: np.ndarray | None = None


def _radial_k(camera: Camera) -> list[float] | None:
    """k1, k2, k3 of the camera's radial distortion (docs/conventions.md), None if none."""
    d = getattr(camera, "distortion", None)
    if d is None:
        return None
    get = d.get if isinstance(d, dict) else (lambda key, default=0.0: getattr(d, key, default))
    k = [float(get(f"k{i}", 0.0) or 0.0) for i in (1, 2, 3)]
    return k if any(k) else None


def sip_from_camera(camera: Camera) -> SipTerms | None:
    """SIP terms of the camera's radial lens distortion; None for a pinhole camera.

    The Brown-Conrady model maps the ideal pinhole offset (U, V) to the observed one,
    ``U (1 + k1 r2 + k2 r2^2 + k3 r2^3)`` with ``r2 = (U^2 + V^2) / f^2``: exactly the
    SIP inverse polynomials AP, BP (order 3, 5 or 7). Their inverse, A and B (observed
    to ideal), is a series, fitted on a grid over the image to order 7 (9 with k2 or
    k3), which leaves well under a tenth of a pixel even for strong distortion.
    """
    k = _radial_k(camera)
    if k is None:
        return None
    order = 9 if (k[1] or k[2]) else 7
    f2 = camera.f_px ** 2
    gu, gv = np.meshgrid(np.linspace(-camera.cx, camera.width - 1 - camera.cx, 32),
                         np.linspace(-camera.cy, camera.height - 1 - camera.cy, 32))
    gu, gv = gu.ravel(), gv.ravel()
    r2 = (gu ** 2 + gv ** 2) / f2
    radial = k[0] * r2 + k[1] * r2 ** 2 + k[2] * r2 ** 3
    terms = _terms(order, 2)  # SIP polynomials start at the quadratic terms
    ap = _polyfit(gu, gv, np.column_stack([gu * radial, gv * radial]), terms, camera.f_px)
    uo, vo = gu * (1 + radial), gv * (1 + radial)
    a = _polyfit(uo, vo, np.column_stack([gu - uo, gv - vo]), terms, camera.f_px)
    return SipTerms(order, _as_matrix(a[:, 0], terms, order), _as_matrix(a[:, 1], terms, order),
                    _as_matrix(ap[:, 0], terms, order), _as_matrix(ap[:, 1], terms, order))


def _terms(order: int, lowest: int) -> list[tuple[int, int]]:
    return [(p, n - p) for n in range(lowest, order + 1) for p in range(n, -1, -1)]


def _design(u: np.ndarray, v: np.ndarray, terms: list[tuple[int, int]]) -> np.ndarray:
    return np.stack([u ** p * v ** q for p, q in terms], axis=-1)


def _polyfit(u: np.ndarray, v: np.ndarray, targets: np.ndarray, terms: list[tuple[int, int]],
             scale: float) -> np.ndarray:
    """Least-squares polynomial coefficients (one column per target) in u and v; the fit
    runs on u/scale, v/scale so cubic and linear columns are of one size."""
    coeffs, *_ = np.linalg.lstsq(_design(u / scale, v / scale, terms), targets, rcond=None)
    powers = np.array([p + q for p, q in terms], dtype=np.float64)
    return coeffs / scale ** powers[:, None]


def _as_matrix(coeffs: np.ndarray, terms: list[tuple[int, int]], order: int) -> np.ndarray:
    out = np.zeros((order + 1, order + 1))
    for c, (p, q) in zip(coeffs, terms, strict=True):
        out[p, q] = c
    return out


def sip_order_for(n_stars: int) -> int:
    """The SIP order a fit to ``n_stars`` matched stars supports (0: TAN only): each
    axis of order n has (n+1)(n+2)/2 - 1 coefficients; ask for three stars per
    coefficient so noise is averaged, not fitted (order 4 from 42 stars: ground frames
    carry differential refraction as well as lens distortion)."""
    for order in (4, 3, 2):
        if n_stars >= 3 * ((order + 1) * (order + 2) // 2 - 1):
            return order
    return 0


def fit_sip(camera: Camera, rotation: Rotation, x: np.ndarray, y: np.ndarray,
            star_vectors: np.ndarray, order: int) -> tuple[np.ndarray, SipTerms | None]:
    """CD matrix and SIP terms fitted to matched stars, as solve-field's tweak does.

    CRPIX stays at the principal point and CRVAL at the solved boresight; the standard
    coordinates of each catalog star ``star_vectors`` (ICRS) are fitted by polynomials of
    order ``order`` in its observed pixel offsets (no constant term: the attitude
    already centres them). The linear part is the CD matrix, the rest becomes SIP
    A and B; AP and BP (the inverse) are fitted on a grid over the image.

    Kept rather than ``astropy.wcs.utils.fit_wcs_from_points(..., sip_degree=order)``:
    that is a nonlinear least-squares fit (it also moves CRPIX) and, on the real test
    frame, tens of times slower for residuals within a few percent of these, and it
    writes no AP/BP inverse for other tools (scripts/bench/bench_library_fits.py prints both).
    """
    ra, dec, cd0 = _cd_matrix(camera, rotation)
    if order < 2:
        return cd0, None
    e, n, b = _tangent_basis(ra, dec)
    s = np.asarray(star_vectors, dtype=np.float64)
    xi = np.degrees((s @ e) / (s @ b))
    eta = np.degrees((s @ n) / (s @ b))
    u, v = np.asarray(x) - camera.cx, np.asarray(y) - camera.cy
    terms = _terms(order, 1)
    coeffs = _polyfit(u, v, np.column_stack([xi, eta]), terms, camera.f_px)
    cd = np.array([[coeffs[0, 0], coeffs[1, 0]], [coeffs[0, 1], coeffs[1, 1]]])
    high = np.linalg.solve(cd, coeffs[2:].T).T  # distortion in pixel units
    a = _as_matrix(np.concatenate([[0, 0], high[:, 0]]), terms, order)
    bm = _as_matrix(np.concatenate([[0, 0], high[:, 1]]), terms, order)
    gu, gv = np.meshgrid(np.linspace(-camera.cx, camera.width - 1 - camera.cx, 24),
                         np.linspace(-camera.cy, camera.height - 1 - camera.cy, 24))
    gu, gv = gu.ravel(), gv.ravel()
    up = gu + _design(gu, gv, terms[2:]) @ high[:, 0]
    vp = gv + _design(gu, gv, terms[2:]) @ high[:, 1]
    inv_terms = terms[2:]  # SIP polynomials start at the quadratic terms
    inv = _polyfit(up, vp, np.column_stack([gu - up, gv - vp]), inv_terms, camera.f_px)
    return cd, SipTerms(order, a, bm, _as_matrix(inv[:, 0], inv_terms, order),
                        _as_matrix(inv[:, 1], inv_terms, order))


def _tangent_basis(ra: float, dec: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """East, north and the direction itself at (ra, dec), ICRS unit vectors."""
    ra_r, dec_r = np.radians(ra), np.radians(dec)
    east = np.array([-np.sin(ra_r), np.cos(ra_r), 0.0])
    north = np.array([-np.sin(dec_r) * np.cos(ra_r), -np.sin(dec_r) * np.sin(ra_r),
                      np.cos(dec_r)])
    centre = np.array([np.cos(dec_r) * np.cos(ra_r), np.cos(dec_r) * np.sin(ra_r),
                       np.sin(dec_r)])
    return east, north, centre


def _cd_matrix(camera: Camera, rotation: Rotation) -> tuple[float, float, np.ndarray]:
    """CRVAL (boresight RA, Dec) and the CD matrix of the pinhole at ``rotation``.

    A pinhole camera is exactly a gnomonic (TAN) projection about its principal point:
    the direction of pixel (x, y) is ``b + X (x - cx)/f + Y (y - cy)/f`` (unnormalised),
    with b, X, Y the camera's z, x, y axes in ICRS. The standard coordinates (east,
    north) of that direction are therefore linear in the pixel offsets: the CD matrix.
    """
    m = rotation.as_matrix()
    x_axis, y_axis, boresight = m[:, 0], m[:, 1], m[:, 2]
    ra, dec = vectors_to_radec(boresight)
    east, north, _ = _tangent_basis(float(ra), float(dec))
    scale = np.degrees(1.0) / camera.f_px
    cd = scale * np.array([[x_axis @ east, y_axis @ east],
                           [x_axis @ north, y_axis @ north]])
    return float(ra), float(dec), cd


def _add_sip(header: fits.Header, sip: SipTerms) -> None:
    header["CTYPE1"] = "RA---TAN-SIP"
    header["CTYPE2"] = "DEC--TAN-SIP"
    for name, coeffs in (("A", sip.a), ("B", sip.b), ("AP", sip.ap), ("BP", sip.bp)):
        if coeffs is None:
            continue
        header[f"{name}_ORDER"] = sip.order
        for p in range(sip.order + 1):
            for q in range(sip.order + 1 - p):
                if coeffs[p, q] != 0.0:
                    header[f"{name}_{p}_{q}"] = float(coeffs[p, q])


def wcs_header(camera: Camera, rotation: Rotation, *, cd: np.ndarray | None = None,
               sip: SipTerms | None = None, date_obs: str | None = None,
               extra: dict | None = None) -> fits.Header:
    """FITS header mapping this camera's pixels to ICRS RA/Dec at ``rotation``.

    Parameters
    ----------
    camera : Camera
        The camera; CRPIX is its principal point plus one (FITS pixels are 1-based).
    rotation : Rotation
        Camera-to-ICRS attitude; CRVAL is its boresight.
    cd : ndarray, optional
        A CD matrix fitted to matched stars (:func:`fit_sip`); default the pinhole's.
    sip : SipTerms, optional
        Distortion terms: fitted (:func:`fit_sip`), else the camera's
        (:func:`sip_from_camera`); none makes a plain TAN header.
    date_obs : str, optional
        ISO 8601 time of the exposure, written as DATE-OBS.
    extra : dict, optional
        More keywords (value or (value, comment)), e.g. EXPTIME.
    """
    ra, dec, cd_pinhole = _cd_matrix(camera, rotation)
    cd = cd_pinhole if cd is None else np.asarray(cd, dtype=np.float64)
    w = WCS(naxis=2)
    w.wcs.ctype = ["RA---TAN", "DEC--TAN"]
    w.wcs.cunit = ["deg", "deg"]
    w.wcs.crpix = [camera.cx + 1.0, camera.cy + 1.0]
    w.wcs.crval = [ra, dec]
    w.wcs.cd = cd
    # With the native pole at 180 deg, the TAN plane's axes are east and north at CRVAL,
    # the frame the CD matrix is built in; stating it keeps the poles consistent too.
    w.wcs.lonpole = 180.0
    w.wcs.radesys = "ICRS"
    w.wcs.equinox = 2000.0
    header = w.to_header()
    sip = sip if sip is not None else sip_from_camera(camera)
    if sip is not None:
        _add_sip(header, sip)
    header["IMAGEW"] = (camera.width, "image width in pixels")
    header["IMAGEH"] = (camera.height, "image height in pixels")
    header["CAMFOV"] = (round(camera.fov_deg, 9), "[deg] horizontal field of view")
    header["CAMFPX"] = (round(camera.f_px, 6), "[pixel] focal length")
    header["CAMCX"] = (camera.cx, "[pixel] principal point x (0-based)")
    header["CAMCY"] = (camera.cy, "[pixel] principal point y (0-based)")
    if date_obs:
        header["DATE-OBS"] = (date_obs, "time of the exposure")
    header["CREATOR"] = (f"startrack {__version__}", "software that wrote this header")
    for key, value in (extra or {}).items():
        header[key] = value
    return header


def write_wcs(path: str | Path, header: fits.Header) -> None:
    """Write ``header`` as a data-less FITS file (like solve-field's .wcs), atomically."""
    path = Path(path)
    with atomic_path(path) as tmp:
        fits.PrimaryHDU(header=header).writeto(tmp, overwrite=True)


def solved_wcs_header(frame, extra: dict | None = None) -> fits.Header:
    """The WCS header of a solved :class:`~startrack.solver._identifier.FrameResult`.

    With a distortion model in the camera its SIP terms are written; otherwise, when
    enough stars are matched, CD and SIP terms are fitted to them (:func:`fit_sip`), so
    the header follows the real optics rather than the ideal pinhole.
    """
    sol = frame.solution
    k, rows = sol.obs_index, sol.cat_index
    order = 0 if sip_from_camera(frame.camera) is not None else sip_order_for(len(k))
    cd, sip = fit_sip(frame.camera, sol.rotation, frame.obs.x[k], frame.obs.y[k],
                      frame.catalog.vectors[rows], order)
    info = {"NMATCH": (len(k), "stars identified"),
            "METHOD": (sol.method, "startrack identification method"),
            "INPUT": (Path(frame.input).name[:60], "the solved input")}
    return wcs_header(frame.camera, sol.rotation, cd=cd, sip=sip,
                      date_obs=date_obs_of(frame.input), extra={**info, **(extra or {})})
