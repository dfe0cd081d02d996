"""A second look past the brightest spots, for frames whose brightest spots are not stars.

The quad search makes its patterns from the :data:`~startrack.matchers._quad.IMAGE_STARS`
brightest spots. On a real frame those can be junk: a caption burned into the image, hot
pixels, the knots of a nebula (the Veil nebula frame solves with its 8 brightest spots
left out, and not with them). When the search finds nothing (``no_match``, not a
timeout), it runs once more, within what is left of the input's time limit, over the spots
in another order (:func:`second_look_order`): the unsaturated spots first where saturated
ones crowd the pattern stars (white text burned into a guide camera's frame saturates, and
can be more spots than any fixed count left out), else the spots after the :data:`SKIP`
brightest. An answer found there is numbered in the whole frame's spots and passes the
same verification and evidence gate as any other.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from startrack.centroids import Centroids
from startrack.io import resident_bytes
from startrack.match_records import Observation
from startrack.matchers import IMAGE_STARS
from startrack.solver._deadline import clock

#: the brightest spots a second look leaves out: half the pattern stars, so that it sees
#: the next ones while the remaining true stars among the first still make patterns
SKIP = IMAGE_STARS // 2
#: a frame needs this many spots past SKIP for a second look (a pattern needs four, and
#: verification others to confirm it)
MIN_LEFT = 8
#: the second look lets the first look's search tables go (and collects them) only when
#: the first look grew the process by more than this: on a narrow field's deep sky they
#: are GBs, and the second look's must come in their place, not on top (a 1 deg frame's
#: blind second look held 2.7 GB with both); on a wide field they are a few MB, and
#: building them again for every unsolved frame cost more than the search (at 20 deg, junk
#: frames paid 120 ms of cone index and 47 ms of collection each). Growth, not size: a
#: process that holds much already (a bench, a compare) paid that on every junk frame.
RELEASE_GROWTH_BYTES = 512 * 2**20
#: saturated spots among the pattern stars that make a second look put the unsaturated
#: spots first: a quarter of them (a frame of bright stars saturates its few brightest)
CROWDING = IMAGE_STARS // 4


def wants_second_look(found, n_spots: int) -> bool:
    """Whether ``found`` (a search's ``FovResult``) failed in a way a second look past
    the brightest spots may mend: no match, on a frame with spots to spare."""
    sol = found.solution
    return not sol.solved and sol.reason == "no_match" and n_spots >= SKIP + MIN_LEFT


def second_look_order(centroids: Centroids) -> tuple[np.ndarray, str]:
    """The spots a second look searches (indices into ``centroids``, in the order it
    takes them) and its stage's name: the unsaturated spots, then the saturated, where at
    least :data:`CROWDING` of the pattern stars are saturated and enough unsaturated spots
    remain for a whole pattern set; else the spots after the :data:`SKIP` brightest."""
    saturated = centroids.saturated
    clear = np.flatnonzero(~saturated)
    if saturated[:IMAGE_STARS].sum() >= CROWDING and len(clear) >= IMAGE_STARS:
        return (np.concatenate([clear, np.flatnonzero(saturated)]),
                "second look, unsaturated spots first")
    return np.arange(SKIP, len(centroids)), f"second look, past the {SKIP} brightest spots"


def reordered(centroids: Centroids, order: np.ndarray) -> Centroids:
    """The spots ``order`` picks, in that order. Where the order is not brightest first,
    their fluxes become ranks (not photometric): a centroid list is always sorted by flux."""
    flux, photometric = centroids.flux[order], centroids.photometric
    if np.any(np.diff(order) < 0):
        flux, photometric = np.arange(len(order), 0, -1, dtype=np.float64), False
    return Centroids(centroids.x[order], centroids.y[order], flux, centroids.saturated[order],
                     centroids.area[order], photometric, centroids.elongation[order])


def renumbered(found, again, centroids: Centroids, order: np.ndarray, sigma_px: float):
    """The second look's solved answer ``again`` (a ``FovResult`` over the spots
    ``order`` picks) as an answer over all of ``centroids``; its time includes the first
    look's (``found``)."""
    sol = dataclasses.replace(again.solution, obs_index=order[again.solution.obs_index])
    flux = None if again.obs.flux is None else centroids.flux
    obs = Observation.from_pixels(centroids.x, centroids.y, again.camera, sigma_px, flux)
    return dataclasses.replace(again, solution=sol, obs=obs).plus_ms(found.solution.identify_ms)


def tables_to_release(start_bytes: int | None) -> bool:
    """Whether the first look's search tables should go before a second look: the
    process's resident memory (:func:`startrack.io.resident_bytes`) grew by more than
    :data:`RELEASE_GROWTH_BYTES` since it was ``start_bytes``, or cannot be read."""
    resident = resident_bytes()
    return resident is None or start_bytes is None or (
        resident - start_bytes > RELEASE_GROWTH_BYTES)


def remaining_ms(timeout_ms: float | None, t0: float) -> float | None:
    """What is left of ``timeout_ms`` (None: no limit) since the deadlines' clock
    (:func:`startrack.solver._deadline.clock`) read ``t0``."""
    if timeout_ms is None:
        return None
    return timeout_ms - (clock() - t0) * 1000.0
