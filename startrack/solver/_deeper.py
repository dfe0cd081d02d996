"""A second look past the brightest spots, for frames whose brightest spots are not stars.

The quad search makes its patterns from the :data:`~startrack.matchers._quad.IMAGE_STARS`
brightest spots. On a real frame those can be junk: a caption burned into the image, hot
pixels, the knots of a nebula (the Veil nebula frame solves with its 8 brightest spots
left out, and not with them). When the search finds nothing (``no_match``, not a
timeout), it runs once more over the spots after the :data:`SKIP` brightest, within what
is left of the input's time limit; an answer found there is numbered in the whole frame's
spots and passes the same verification and evidence gate as any other.
"""

from __future__ import annotations

import dataclasses
import time

from startrack.centroids import Centroids
from startrack.match_records import Observation
from startrack.matchers import IMAGE_STARS

#: the brightest spots a second look leaves out: half the pattern stars, so that it sees
#: the next ones while the remaining true stars among the first still make patterns
SKIP = IMAGE_STARS // 2
#: a frame needs this many spots past SKIP for a second look (a pattern needs four, and
#: verification others to confirm it)
MIN_LEFT = 8


def wants_second_look(found, n_spots: int) -> bool:
    """Whether ``found`` (a search's ``FovResult``) failed in a way a second look past
    the brightest spots may mend: no match, on a frame with spots to spare."""
    sol = found.solution
    return not sol.solved and sol.reason == "no_match" and n_spots >= SKIP + MIN_LEFT


def without_brightest(centroids: Centroids) -> Centroids:
    """``centroids`` without the :data:`SKIP` brightest (still brightest first)."""
    k = SKIP
    return Centroids(centroids.x[k:], centroids.y[k:], centroids.flux[k:],
                     centroids.saturated[k:], centroids.area[k:], centroids.photometric,
                     centroids.elongation[k:])


def renumbered(found, again, centroids: Centroids, sigma_px: float):
    """The second look's solved answer ``again`` (a ``FovResult`` over the spots after
    the :data:`SKIP` brightest) as an answer over all of ``centroids``; its time includes
    the first look's (``found``)."""
    sol = dataclasses.replace(again.solution, obs_index=again.solution.obs_index + SKIP)
    flux = None if again.obs.flux is None else centroids.flux
    obs = Observation.from_pixels(centroids.x, centroids.y, again.camera, sigma_px, flux)
    return dataclasses.replace(again, solution=sol, obs=obs).plus_ms(found.solution.identify_ms)


def remaining_ms(timeout_ms: float | None, t0: float) -> float | None:
    """What is left of ``timeout_ms`` (None: no limit) since ``time.perf_counter()`` was
    ``t0``."""
    if timeout_ms is None:
        return None
    return timeout_ms - (time.perf_counter() - t0) * 1000.0
