"""The Python API of docs/conventions.md: ``startrack.solve(...)`` and ``startrack.Solver``.

A :class:`Solver` loads the catalog and database once and solves frame after frame; each
answer is a :class:`SolveResult` whose ``to_dict()`` is the JSON record that
``startrack identify --format json`` prints.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from startrack.api._build import SequenceChoice, SolverRequest, build_solver
from startrack.api._keywords import (
    api_camera,
    api_prior,
    api_size,
    api_time,
    check_solver_numbers,
    keyword_message,
)
from startrack.api._result import SolveResult
from startrack.camera import Camera
from startrack.centroids import (
    MAX_CENTROID_COORD_PX,
    Centroids,
    bad_centroid_row,
)
from startrack.defaults import DEFAULT_FOV_TOLERANCE, DEFAULT_METHOD, DEFAULT_TIMEOUT_MS
from startrack.errors import InputError, as_builtin
from startrack.input_checks import NumberTypeError
from startrack.io import check_pixels
from startrack.solver import FrameInput, Options, image_input, read_input, user_hints
from startrack.units import degree_options, scale_value


def _builtin_errors(method):
    """``method`` raising the API's errors as built-in subclasses
    (:func:`startrack.errors.as_builtin`)."""
    @functools.wraps(method)
    def wrapper(*args, **kwargs):
        try:
            return method(*args, **kwargs)
        except InputError as exc:
            raised = as_builtin(exc)
            text = keyword_message(str(raised))
            if text != str(raised):  # the message names keywords, not options
                raised = type(raised)(text)
            elif raised is exc:
                raise
            raise raised from None
    return wrapper


class Solver:
    r"""Loads catalog and database once; :meth:`solve` answers one frame at a time.

    Give the camera as ``fov_deg`` (with ``size`` for centroid arrays; images give their
    own size) or ``camera``; either is nominal, good to ``fov_tolerance``. With neither,
    the field of view is searched (:data:`startrack.defaults.BLIND_FOV_RANGE`). The
    keywords are ``startrack identify``'s options; angles may be astropy Quantities.

    Parameters
    ----------
    fov_deg : float, optional
        The horizontal field of view, degrees.
    camera : Camera, str, Path or mapping, optional
        A :class:`~startrack.camera.Camera`, a camera file or its keys
        (docs/conventions.md).
    size : (int, int), optional
        (width, height) in pixels of the frames given as centroid arrays.
    method : str
        The matcher (:func:`startrack.matchers.available_methods`).
    sky : str, optional
        ``"random"``, ``"hipparcos"``, ``"gaia"``, ``"tycho2"`` or a catalog file;
        default: chosen for the field of view (docs/conventions.md, "Default sky").
    mag_limit, epoch, sigma_px, max_stars, timeout_ms, fov_tolerance
        As ``identify``'s options of the same names (``timeout_ms`` defaults to
        ``identify``'s 60 s; None: no time limit).
    track : bool
        The frames given to :meth:`solve` are one sequence, in order: the first is solved
        lost-in-space, each later one by tracking from the attitudes before it (falling
        back to lost-in-space); :meth:`reset` starts a new sequence.
    prior : (float, float, float), optional
        (ra, dec, roll) in degrees, 1-sigma ``prior_sigma_deg``: seeds the first frame of
        a sequence, or every frame without ``track``.
    time : str or astropy.time.Time, optional
        The observation time (ISO 8601), for the aberration correction.
    ra, dec, radius, scale_low, scale_high, scale_units, pixel_size_um, downsample
        Hints (:mod:`startrack.solver._hints`): the boresight lies within ``radius`` of
        (ra, dec); the scale lies in [scale_low, scale_high] ``scale_units``
        ("degwidth", "arcsecperpix" or "focalmm" with ``pixel_size_um``); centroids
        are found on the image binned ``downsample`` x ``downsample``.
    header_hints : bool
        Use a FITS input's WCS, DATE-OBS and EXPTIME (default on).
    config : str or Path, optional
        A preset (``configs/*.toml`` or its name) whose camera and sky are the defaults.

    Raises
    ------
    ValueError
        A keyword out of its documented range (an :class:`~startrack.errors.InputError`).
    TypeError
        A keyword of the wrong type, e.g. ``prior=(1, 2)``.
    FileNotFoundError
        A camera or preset file that does not exist.

    Examples
    --------
    A frame of 20 degrees seen at a known attitude (seeded), solved from its centroids:

    >>> import numpy as np
    >>> from startrack import Solver
    >>> from startrack.attitude import from_radec_roll
    >>> from startrack.camera import Camera
    >>> from startrack.simulate import observe
    >>> from startrack.sky import load_sky
    >>> camera = Camera.from_fov(1024, 1024, 20.0)
    >>> truth = from_radec_roll(120.0, -30.0, 15.0)
    >>> scene = observe(load_sky("random", camera), camera, truth, np.random.default_rng(7))
    >>> solver = Solver(fov_deg=20.0, size=(1024, 1024), sky="random", track=True)
    >>> first = solver.solve(np.column_stack([scene.x, scene.y]))
    >>> first.mode, round(first.ra_deg, 3), round(first.dec_deg, 3), round(first.roll_deg, 3)
    ('lost_in_space', 120.0, -30.0, 15.0)
    >>> solver.solve(np.column_stack([scene.x, scene.y])).mode
    'tracking'
    """

    @_builtin_errors
    def __init__(self, fov_deg: float | None = None, *, camera: Camera | str | Path | None = None,
                 size: tuple[int, int] | None = None, method: str = DEFAULT_METHOD,
                 sky: str | None = None, mag_limit: float | None = None,
                 epoch: float | None = None, sigma_px: float | None = None,
                 max_stars: int | None = None,
                 timeout_ms: float | None = DEFAULT_TIMEOUT_MS,
                 track: bool = False, prior: tuple[float, float, float] | None = None,
                 prior_sigma_deg: float = 1.0, time: str | None = None,
                 fov_tolerance: float = DEFAULT_FOV_TOLERANCE, ra=None, dec=None,
                 radius=None, scale_low=None, scale_high=None, scale_units: str = "degwidth",
                 pixel_size_um: float | None = None, downsample: int = 1,
                 header_hints: bool = True, config: str | Path | None = None) -> None:
        # what pickling carries: a Solver goes to a process pool as its options
        self._given = {k: v for k, v in locals().items() if k not in ("self", "__class__")}
        deg = degree_options(dict(fov_deg=fov_deg, prior=prior, ra=ra, dec=dec,
                                  radius=radius, prior_sigma_deg=prior_sigma_deg))
        fov_deg, prior, prior_sigma_deg = deg["fov_deg"], deg["prior"], deg["prior_sigma_deg"]
        check_solver_numbers(fov_deg=fov_deg, fov_tolerance=fov_tolerance, sigma_px=sigma_px,
                             mag_limit=mag_limit, epoch=epoch, max_stars=max_stars,
                             timeout_ms=timeout_ms, prior_sigma_deg=prior_sigma_deg)
        time, size, prior = api_time(time), api_size(size), api_prior(prior)
        scale_low, scale_units = scale_value(scale_low, scale_units, "scale_low")
        scale_high, scale_units = scale_value(scale_high, scale_units, "scale_high")
        hints = user_hints(deg["ra"], deg["dec"], deg["radius"], scale_low, scale_high,
                           scale_units, pixel_size_um,
                           fov_given=fov_deg is not None or camera is not None)
        options = Options(method=method, camera=api_camera(camera), fov_deg=fov_deg, size=size,
                          sky=sky, mag_limit=mag_limit, epoch=epoch, max_stars=max_stars,
                          sigma_px=sigma_px, timeout_ms=timeout_ms, time=time,
                          fov_tolerance=fov_tolerance, hints=hints,
                          header_hints=bool(header_hints), downsample=downsample)
        self._solver = build_solver(SolverRequest(options, config, SequenceChoice(
            track, prior, prior_sigma_deg)))

    def __getstate__(self) -> dict:
        """A Solver pickles as its options (to a process pool, a Dask worker): the copy
        loads its own databases, and a tracking copy starts a new sequence."""
        return dict(self._given)

    def __setstate__(self, state: dict) -> None:
        self.__init__(**state)

    def reset(self) -> None:
        """Start a new sequence (``track=True``): the next frame is solved lost-in-space."""
        self._solver.reset()

    @_builtin_errors
    def solve(self, source: str | Path | np.ndarray) -> SolveResult:
        """Solve one frame.

        Parameters
        ----------
        source : str, Path or numpy.ndarray
            A path (PNG, TIFF, FITS image or centroid CSV), a 2-D image array, or an
            N x 2 / N x 3 array of centroids (x, y[, flux]; brightest first when there is
            no flux), pixels as in docs/conventions.md.

        Returns
        -------
        SolveResult
            The answer; ``solved`` is False (with a ``reason``) when the frame holds too
            few stars or no hypothesis passes verification.

        Raises
        ------
        FileNotFoundError
            ``source`` names no file.
        ValueError
            An unreadable input, or centroids that are not finite pixel positions.
        TypeError
            An array of a dtype that holds no light (complex, text).
        """
        try:
            frame = as_frame_input(source, self._solver.options.downsample)
        except InputError:
            self._solver.skip()  # an unreadable frame of a sequence: time passes
            raise
        return SolveResult(self._solver.solve(frame))


def solve(source: str | Path | np.ndarray, **options) -> SolveResult:
    """Solve one frame: ``Solver(**options).solve(source)``.

    Parameters
    ----------
    source : str, Path or numpy.ndarray
        A path (image or centroid CSV), a 2-D image, or N x 2 / N x 3 centroids
        (:meth:`Solver.solve`).
    **options
        :class:`Solver`'s keywords (``fov_deg``, ``size``, ``sky``, ``method``, ...).

    Returns
    -------
    SolveResult
        The attitude, the identified stars and the JSON record of the frame.

    Raises
    ------
    ValueError, TypeError, FileNotFoundError
        Bad options or an unreadable input, as :class:`Solver` and :meth:`Solver.solve`.

    Examples
    --------
    A frame rendered (seeded) from a random sky at a known attitude, solved from its pixels:

    >>> import numpy as np
    >>> import startrack
    >>> from startrack.attitude import from_radec_roll
    >>> from startrack.simulate import SensorModel, observe, render_frame
    >>> camera = startrack.Camera.from_fov(640, 480, 20.0)
    >>> rng = np.random.default_rng(3)
    >>> truth = from_radec_roll(80.0, 25.0, -40.0)
    >>> scene = observe(startrack.load_sky("random", camera), camera, truth, rng)
    >>> image = render_frame(scene, camera, SensorModel(), rng)
    >>> result = startrack.solve(image, fov_deg=20.0, sky="random")
    >>> result.solved, round(result.ra_deg, 2), round(result.dec_deg, 2), round(result.roll_deg)
    (True, 80.0, 25.0, 320)
    >>> len(result.stars) == len(scene)
    True
    """
    return Solver(**options).solve(source)


#: an N x 2 / N x 3 centroid array holds at most this many rows (160 MB as float64)
MAX_ARRAY_CENTROIDS = 10_000_000


def as_frame_input(source: str | Path | np.ndarray, downsample: int = 1) -> FrameInput:
    if isinstance(source, str | Path):
        return read_input(source, downsample=downsample)
    array = np.asarray(source)
    if array.dtype.kind not in "uif":
        raise NumberTypeError(f"cannot solve an array of dtype {array.dtype}: give real numbers "
                        "(a complex image's phase is not light)")
    # Two or three columns are centroids whatever the dtype: no star can be found in an
    # image two or three pixels wide (docs/conventions.md).
    if array.ndim == 2 and array.shape[1] in (2, 3):
        if len(array) > MAX_ARRAY_CENTROIDS:
            raise InputError(f"<array>: {len(array):,} centroids, above the limit of "
                             f"{MAX_ARRAY_CENTROIDS:,} (a frame holds tens to thousands)")
        array = array.astype(np.float64)
        bad = bad_centroid_row(array)
        if bad is not None:
            raise InputError(f"<array>: row {bad}: x, y and flux must be finite numbers, x "
                             f"and y within {MAX_CENTROID_COORD_PX:g} px")
        if array.shape[1] == 3:
            return FrameInput("<array>", Centroids(array[:, 0], array[:, 1], array[:, 2]))
        ranks = np.arange(len(array), 0, -1.0)  # listed brightest first
        return FrameInput("<array>", Centroids(array[:, 0], array[:, 1], ranks,
                                               photometric=False))
    if array.ndim == 2:  # the pixel limit of an image file, before any work on it
        check_pixels(array.shape[1], array.shape[0], "<array>")
        return image_input(array, "<array>", downsample=downsample)
    raise InputError(f"cannot solve an array of shape {array.shape}: give a 2-D image or "
                     "an N x 2 / N x 3 array of centroids")

__all__ = ["Solver", "solve"]
