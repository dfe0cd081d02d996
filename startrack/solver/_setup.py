"""Each input's camera and sky, as :class:`~startrack.solver._pipeline.Pipeline` decides
them: the options, else the sidecar beside the input, else the defaults."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

from startrack.camera import Camera
from startrack.errors import InputError
from startrack.sky import SkySpec, deeper_sky_note, default_sky_kind, resolve_sky, sky_spec
from startrack.solver._inputs import FrameInput
from startrack.solver._options import Options, with_fov


def decide_setup(opt: Options, frame: FrameInput, side_camera: Camera | None,
                 side_sky: SkySpec | None,
                 note: Callable[[str | None], None]) -> tuple[Camera | None, SkySpec]:
    """The camera (None: an unknown field of view, a blind search) and sky of ``frame``
    under ``opt``, given its sidecar's camera and sky (None: no sidecar); ``note`` is told
    when a deeper sky would serve the camera better."""
    side_sky = opt.sky_spec or side_sky
    camera = opt.camera or (side_camera if opt.fov_deg is None else None)
    if camera is None and opt.fov_deg is not None:  # --fov overrides the sidecar's
        side_size = (side_camera.width, side_camera.height) if side_camera else None
        size = opt.size or frame.size or side_size
        if size is None:
            raise InputError(f"{frame.name}: a centroid list with --fov needs the image "
                             "size (--size WxH) or use --camera FILE")
        camera = with_fov(size, opt.fov_deg, side_camera)
    given = sky_spec(opt.sky) if opt.sky else None
    if given is None and side_sky is None:
        given = SkySpec(kind=default_sky_kind(camera))
        note(deeper_sky_note(camera, given.kind))
    sky = side_sky if side_sky is not None and (
        given is None or (side_sky.kind, side_sky.path) == (given.kind, given.path)) \
        else given
    if opt.epoch is not None:
        sky = dataclasses.replace(sky, epoch=opt.epoch)
    if opt.mag_limit is not None:
        sky = dataclasses.replace(sky, mag_limit=opt.mag_limit)
    return camera, resolve_sky(sky, camera)
