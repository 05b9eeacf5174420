"""Noticing that the localizer has lost track: the plan no longer explains the scans."""

from __future__ import annotations

import dataclasses
import math
from collections import deque
from dataclasses import dataclass, field
from typing import Annotated

from pydantic.dataclasses import dataclass as pydantic_dataclass

from .._settings import SETTINGS, Flag, Real, Settings, Whole


@pydantic_dataclass(frozen=True, config=SETTINGS)
class LostRule(Settings):
    """When the `Localizer` declares itself lost.

    The match score of a scan is the share of its points within `max_correspondence_distance` of
    the plan after alignment, over the whole scan (0 for a scan too small to align): returns the
    `OcclusionRule` left out and, on a plan whose walls stop every beam (not a SLAM map's
    cells, `PlanMap.cells_mark_returns`), returns beyond the walls seen from the prediction count
    as unexplained. The localizer is
    lost when the mean score over the last `window` scans falls below `min_score`, or when
    `max_rejections` scans in a row were rejected by the acceptance gate. A scan held as
    clutter (see `min_score`) is not scored, but it is one of the last `window`: the score is
    over recent scans only, so a window with a scan held in it says nothing (a crowd's first
    scans, rejected before any scan was explained well enough to continue, are not still
    counted twenty scans on).

    Attributes:
        window: scans the score is averaged over (>= 1).
        min_score: lowest acceptable mean score, in [0, 1], until the track has learned how
            little of its scans this plan explains where the localizer is right: then the lower
            of this and that share (`relaxed_to`, `Recovery.explained_bar`). The `Localizer` checks every scan
            scoring below it against the last well explained scan (`ContinuityRule`): a scan
            that continues it is clutter and does not count (in a cluttered room the plan may
            explain only a third of the scans while every fit is sound); one that does not is
            not trusted. A scan whose returns on or beyond the plan's walls (those the occlusion
            rule kept) the plan explains at least as well as a continuation must overlap
            (`ContinuityRule.min_overlap`) counts as clutter too: a crowd hides most walls.
        max_rejections: rejections in a row that mean lost (>= 1).
        relaxes: whether `min_score` relaxes to what the track has learned (False: the bar as
            set, always).
    """

    window: Annotated[int, Whole(ge=1, le=10_000)] = 5
    min_score: Annotated[float, Real(ge=0.0, le=1.0)] = 0.35
    max_rejections: Annotated[int, Whole(ge=1, le=10_000)] = 3
    relaxes: Flag = True

    def relaxed_to(self, explained: float | None) -> LostRule:
        """This rule with `min_score` lowered to `explained` where that is lower (None, or not
        `relaxes`: unchanged): the share of its scan a sound fit may explain on this plan
        (`Recovery.explained_bar`; see `AcceptanceGate.relaxed_to`)."""
        if explained is None or not self.relaxes or explained >= self.min_score:
            return self
        return dataclasses.replace(self, min_score=explained)


@dataclass
class LostDetector:
    """The running state `LostRule` is applied to: the last `window` scans (`recent`: each one's
    score, None for one held as clutter), the rejections in a row, and the rule the last update
    judged them by (`judged_by`: `rule` relaxed to what the track has learned of the plan; None
    before the first update)."""

    rule: LostRule = field(default_factory=LostRule)
    recent: deque[float | None] = field(default_factory=deque)
    rejections: int = 0
    judged_by: LostRule | None = None

    def hold(self, accepted: bool = False) -> bool:
        """A scan that tells nothing about being lost (clutter, continuing the last scan the plan
        explained well, or a crowd): not scored, but one of the last `window`; its fit, if the
        gate `accepted` it, ends a row of rejections, which a rejected one neither ends nor
        lengthens. Returns whether lost."""
        self._push(None)
        if accepted:
            self.rejections = 0
        return self.lost

    def update(self, score: float, accepted: bool, rule: LostRule | None = None) -> bool:
        """Adds one scan's score (NaN counts as 0) and acceptance; returns whether lost, by `rule`
        (the bars this update applies, `LostRule.relaxed_to`; default `self.rule`), which the
        `lost` verdict keeps until the next update."""
        self.judged_by = self.rule if rule is None else rule
        self._push(0.0 if math.isnan(score) else score)
        self.rejections = 0 if accepted else self.rejections + 1
        return self.lost

    def _push(self, score: float | None) -> None:
        self.recent.append(score)
        while len(self.recent) > self.rule.window:
            self.recent.popleft()

    @property
    def scores(self) -> list[float]:
        """The scores of the last `window` scans, oldest first (those held as clutter left out)."""
        return [s for s in self.recent if s is not None]

    @property
    def score(self) -> float:
        """Mean score of the last `window` scans that were scored (NaN if none was)."""
        scores = self.scores
        return sum(scores) / len(scores) if scores else math.nan

    @property
    def lost(self) -> bool:
        """Whether the rule says lost now (as the last update judged, `judged_by`)."""
        return self.lost_by(self.rule if self.judged_by is None else self.judged_by)

    def lost_by(self, rule: LostRule) -> bool:
        """Whether `rule` says lost over the scores and rejections so far: by the score only when
        each of the last `rule.window` scans was scored."""
        full = len(self.scores) >= rule.window
        return (full and self.score < rule.min_score) or self.rejections >= rule.max_rejections

    def declare_lost(self) -> None:
        """Lost from now until the next `reset` (the robot was reported moved or unknown)."""
        self.rejections = max(self.rejections, self.rule.max_rejections)

    def reset(self) -> None:
        """Forgets the history (after a relocalization or a pose given by the user)."""
        self.recent.clear()
        self.rejections = 0
        self.judged_by = None
