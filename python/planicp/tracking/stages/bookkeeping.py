"""Stage 10 of `Localizer.update`: what the next updates need from this scan (`keep_records`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..decisions import Bookkeeping, FitDecision, ScoreDecision
from ..icp_result import IcpResult
from ..recovery import Recovery
from .rules import Rules


def keep_records(
    recovery: Recovery,
    fit: FitDecision,
    score: ScoreDecision,
    result: IcpResult | None,
    scan_points: int,
    accepted: bool,
    relocalized: bool,
    lost: bool,
    rules: Rules,
    *,
    points: NDArray[np.float64] | None = None,
) -> Bookkeeping:
    """Whether the scan becomes the continuity anchor (an `accepted` fit the plan explains well,
    or clutter that continues the last anchor), and, for a soundly tracked scan (accepted, well
    explained, not `relocalized`, not `lost`), what the recovery learns of this plan and scanner
    from it: the share of its returns beyond the walls seen from the prediction (see
    `Recovery.beyond_limit`), or, where the occlusion rule did not classify them (a prediction
    too uncertain for it), seen from the fit's pose (of the scan's `points`, base frame, when
    given), and the share of its `scan_points` the fit `result` explained (over
    the whole scan, as the recovery's fits count theirs: returns left out in front of the walls
    are not explained; see `Recovery.explained_seen`); and whether the scan vouches for the pose
    (that share at least `explained_seen` before it is recorded). A fit that passes only the bars
    relaxed to what the plan explains (`Rules.gate`, `Rules.lost`), not those as set
    (`Rules.gate_as_set`, `Rules.lost_as_set`), keeps the track but is not sound: it teaches
    nothing, so that the bars it passed cannot fall further, and vouches for nothing."""
    anchored = bool(accepted and (score.continues or not score.poor))
    share = explained = None
    sound = accepted and not score.poor and not relocalized and not lost
    if sound and result is not None:
        sound = rules.passes_as_set(result, score.score)
    beyond = fit.beyond
    if sound and beyond is None and result is not None and points is not None and rules.occlusion is not None:
        # Where each step moves the robot metres (one scan a metre or two, a noisy odometry) the
        # prediction is never trusted enough for the occlusion rule; a bar learned from no scan
        # stays at `max_beyond`, which a SLAM map's true places exceed (fhw with every other
        # scan: 29-63 %, and the robot, lost at its 15th update, was never found again).
        beyond = rules.occlusion.classify(points, result.pose)[1]
    if sound and beyond is not None and len(beyond):
        share = float(np.mean(beyond))
        recovery.observe_beyond(share)
    vouched = False
    if sound and result is not None and scan_points > 0:
        explained = result.num_inliers / scan_points
        vouched = explained >= recovery.explained_seen
        recovery.observe_explained(explained)
    return Bookkeeping(anchored, share, explained, vouched)
