"""Stars to identities to attitude: run one matcher's hypotheses through verification."""

from __future__ import annotations

import time

import numpy as np
from scipy.spatial.transform import Rotation

from startrack._core.verify.entry_points import residual_arcsec
from startrack.match_records import Hypothesis, MatchDiagnostics, Observation, Solution
from startrack.matchers import Matcher
from startrack.solver._deadline import Deadline
from startrack.verify import FrameVerifier, Verification, VerifyConfig, verify


def residuals_arcsec(rotation: Rotation | np.ndarray, obs: Observation, obs_index: np.ndarray,
                     cat_vectors: np.ndarray) -> np.ndarray:
    """Angle between each observed star, rotated to the sky (by a Rotation or its 3 x 3
    matrix, camera to sky), and its catalog star."""
    matrix = rotation if isinstance(rotation, np.ndarray) else rotation.as_matrix()
    return residual_arcsec(np.ascontiguousarray(obs.vectors, dtype=np.float64),
                           np.ascontiguousarray(obs_index, dtype=np.int64),
                           np.ascontiguousarray(matrix, dtype=np.float64),
                           np.ascontiguousarray(cat_vectors, dtype=np.float64))


def identify(obs: Observation, matcher: Matcher, config: VerifyConfig | None = None,
             timeout_ms: float | None = None, deadline: Deadline | None = None) -> Solution:
    """Try the matcher's hypotheses in order; return the first one verification accepts.

    The matcher is told verification's first-test radius (``screen_rad``), so that it
    may drop the hypotheses that test would refuse before they reach this loop: the
    answer is the same either way (unless the refused ones would have used up
    ``config.max_hypotheses``), and ``hypotheses`` counts only those handed over.
    The work is bounded on every machine alike by the matcher's own budgets (patterns
    tried) and ``config.max_hypotheses``; ``timeout_ms`` adds a wall-clock limit, checked
    between hypotheses: when it trips the frame is not solved, with reason "timeout".
    ``deadline`` is the input's one limit shared with the stages before and after this one
    (:mod:`startrack.solver._deadline`); the sooner of the two applies.
    The time covers matching, verification and the attitude, with the database loaded.
    """
    config = config or VerifyConfig()
    diag = MatchDiagnostics()
    t0 = time.perf_counter()
    deadline = Deadline.after_ms(timeout_ms).earliest(deadline)
    seen: set[tuple] = set()
    checker = None
    result = None
    timed_out = False
    if len(obs) >= 3:
        timed_out = deadline.passed()  # spent by the stages before this one
        screen_rad = config.radius_px(obs) / obs.camera.f_px  # verify()'s first test
        for hyp in [] if timed_out else matcher.hypotheses(obs, diag, screen_rad):
            if deadline.passed():
                timed_out = True
                break
            # A repeat of a refused hypothesis is skipped (the first cannot be one).
            key = _key(hyp) if seen else None
            if key in seen:
                continue
            diag.hypotheses += 1
            # One verifier for the frame: each hypothesis looks up its own cone in it.
            checker = checker or FrameVerifier(obs, matcher.database, config)
            check = verify(hyp, obs, matcher.database, config, checker)
            if check.accepted:
                result = check
                break
            seen.add(_key(hyp) if key is None else key)
            if diag.hypotheses >= config.max_hypotheses:
                break
    elapsed = (time.perf_counter() - t0) * 1000.0
    if result is None:
        reason = "no_match" if len(obs) >= 3 else "too_few_stars"
        if timed_out:
            reason = "timeout"
        return Solution(False, matcher.name, diagnostics=diag, identify_ms=elapsed,
                        reason=reason)
    return _solved(result, obs, matcher, diag, elapsed)


def _key(hyp: Hypothesis) -> tuple:
    return tuple(sorted(zip(np.asarray(hyp.obs_index).tolist(),
                            np.asarray(hyp.cat_index).tolist(), strict=True)))


def _solved(result: Verification, obs: Observation, matcher: Matcher, diag: MatchDiagnostics,
            elapsed: float) -> Solution:
    """The Solution of an accepted hypothesis, identities by observed index."""
    rotation = result.rotation
    if result.residual_arcsec is not None:  # the one-call path: obs_index ascending
        obs_index, cat_index, residuals = (result.obs_index, result.cat_index,
                                           result.residual_arcsec)
    else:
        order = np.argsort(result.obs_index)
        obs_index, cat_index = result.obs_index[order], result.cat_index[order]
        residuals = residuals_arcsec(result.matrix, obs, obs_index,
                                     matcher.database.vectors[cat_index])
    return Solution(
        solved=True,
        method=matcher.name,
        rotation=rotation,
        obs_index=obs_index,
        cat_index=cat_index,
        residual_arcsec=residuals,
        false_probability=result.false_probability,
        diagnostics=diag,
        identify_ms=elapsed,
    )
