"""A FITS TAN world coordinate system for the pinhole camera at a given attitude."""

from __future__ import annotations

import numpy as np
from astropy.io import fits
from astropy.wcs import WCS
from scipy.spatial.transform import Rotation

from startrack.camera import Camera
from startrack.sky.catalog import vectors_to_radec


def wcs_header(camera: Camera, rotation: Rotation) -> fits.Header:
    """TAN WCS header mapping this camera's pixels to ICRS RA/Dec at ``rotation``.

    A pinhole camera is exactly a gnomonic (TAN) projection about its principal point:
    the direction of pixel (x, y) is ``b + X (x - cx)/f + Y (y - cy)/f`` (unnormalised),
    with b, X, Y the camera's z, x, y axes in ICRS. The standard coordinates (east,
    north) of that direction are therefore linear in the pixel offsets, which is the CD
    matrix below. FITS pixels are 1-based, so CRPIX = (cx + 1, cy + 1).
    """
    m = rotation.as_matrix()
    x_axis, y_axis, boresight = m[:, 0], m[:, 1], m[:, 2]
    ra, dec = vectors_to_radec(boresight)
    ra_r, dec_r = np.radians(float(ra)), np.radians(float(dec))
    east = np.array([-np.sin(ra_r), np.cos(ra_r), 0.0])
    north = np.array([-np.sin(dec_r) * np.cos(ra_r), -np.sin(dec_r) * np.sin(ra_r),
                      np.cos(dec_r)])
    scale = np.degrees(1.0) / camera.f_px
    cd = scale * np.array([[x_axis @ east, y_axis @ east],
                           [x_axis @ north, y_axis @ north]])
    w = WCS(naxis=2)
    w.wcs.ctype = ["RA---TAN", "DEC--TAN"]
    w.wcs.cunit = ["deg", "deg"]
    w.wcs.crpix = [camera.cx + 1.0, camera.cy + 1.0]
    w.wcs.crval = [float(ra), float(dec)]
    w.wcs.cd = cd
    # With the native pole at 180 deg, the TAN plane's axes are east and north at CRVAL,
    # the frame the CD matrix is built in; stating it keeps the poles consistent too.
    w.wcs.lonpole = 180.0
    w.wcs.radesys = "ICRS"
    w.wcs.equinox = 2000.0
    header = w.to_header()
    header["IMAGEW"] = (camera.width, "image width in pixels")
    header["IMAGEH"] = (camera.height, "image height in pixels")
    return header
