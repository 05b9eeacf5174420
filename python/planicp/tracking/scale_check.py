"""Noticing, while tracking, a plan whose scale is off: the evidence of the accepted fits.

A plan read at a wrong metres per pixel is tracked smoothly (every fit accepted, decimetres off),
so the tracking's own verdicts never say so. `ScaleMonitor` watches the accepted fits instead:
every `ScaleRule.every`-th one, `scale_fit` (`planicp.tracking.scale_evidence`) measures the scale
of the scan that best fits the plan at the fit's pose. On a correct plan that is 1 to within a
tenth of a percent; on a plan 3 % off it is 1.03 on every scan, whichever room the robot is in.

A fit's scale counts only when the scan scaled by it explains clearly more of its returns than the
unscaled scan at the rigid fit does (`ScaleRule.min_gain`): otherwise the simpler model, no scale
error, stands. (In a scan mostly of clutter, the similarity fit finds a scale of its own for a few
walls and the furniture, which explains no more of the scan.) The verdict is a robust test over the
fits so far: the plan is suspect when the median scale error
is at least `tolerance` and at least `agreement` of the fits lie beyond half of it on the same side
(a sign test: a correct plan's fits scatter about zero, and the furniture a fit does not
down-weight pulls single scans, not most of them), after at least `min_fits` fits. The monitor
only observes: it never changes a pose. Metres, map frame; scale errors as ratios.
"""

from __future__ import annotations

import math
import warnings
from collections import deque
from dataclasses import dataclass, field
from typing import Annotated

import numpy as np
from numpy.typing import NDArray
from pydantic.dataclasses import dataclass as pydantic_dataclass

from .._settings import SETTINGS, Flag, Real, Settings, Whole
from .._validation import Pose
from ..plans.plan_map import PlanMap
from .scale_evidence import WallLookup, scale_fit


class PlanScaleWarning(UserWarning):
    """The plan's scale looks wrong: the scans fit it best scaled (see `ScaleEstimate`)."""


@pydantic_dataclass(frozen=True, config=SETTINGS)
class ScaleRule(Settings):
    """When the `Localizer` says the plan's scale is off (`Estimate.scale`).

    Attributes:
        enabled: watch the scale at all (the check only observes; off saves its ~1 ms).
        every: one accepted fit in `every` is measured (>= 1): at 10 scans a second and the
            default 3, 16 fits in the first 50 scans, at about a third of a millisecond per update.
        min_fits: fewest measured fits before a verdict (>= 1).
        window: the verdict and the estimate use the last `window` fits (>= `min_fits`).
        tolerance: smallest scale error (a ratio: 0.02 is 2 %) that makes the plan suspect.
        agreement: share of the fits, in (0.5, 1], that must lie beyond `tolerance` / 2 on the
            side of the median (a fit counted as 0 for want of `min_gain` is not among them).
        max_distance: metres a return may lie from its wall (plus 15 % of its range) to count.
        min_gain: a fit's scale counts only when the scan scaled by it explains at least this
            share of its returns more than the rigid fit does (within 5 cm of their walls);
            otherwise the fit counts as scale error 0. Measured on the office and generated
            floors: on correct plans the gain is within +-0.006 (5th to 95th percentile), on
            plans 3 % and 10 % off 0.03 to 0.30 once tracking has settled (`tests/test_plan_scale.py`,
            `benches/plan_scale.py`).
    """

    enabled: Flag = True
    every: Annotated[int, Whole(ge=1, le=10_000)] = 3
    min_fits: Annotated[int, Whole(ge=1, le=10_000)] = 8
    window: Annotated[int, Whole(ge=1, le=100_000)] = 100
    tolerance: Annotated[float, Real(gt=0.0, lt=0.5)] = 0.02
    agreement: Annotated[float, Real(gt=0.5, le=1.0)] = 0.6
    max_distance: Annotated[float, Real(gt=0.0, unit="metres")] = 0.3
    min_gain: Annotated[float, Real(ge=0.0, le=1.0)] = 0.05


@dataclass(frozen=True)
class ScaleEstimate:
    """What the accepted fits so far say about the plan's scale.

    Attributes:
        factor: multiply the plan's coordinates (an image's metres per pixel) by this to make it
            true to the building (`PlanMap.scaled`): 1 / (1 + the median scale error of the
            fits). 1.031 means the plan is drawn about 3 % too small.
        std: robust standard deviation of `factor` from the fits' spread (1.4826 MAD / sqrt(n)).
        fits: the fits measured in the window.
        agreement: share of them beyond `ScaleRule.tolerance` / 2 on the median's side.
        suspect: the plan's scale is off by at least `ScaleRule.tolerance` (see `ScaleRule`).
    """

    factor: float
    std: float
    fits: int
    agreement: float
    suspect: bool

    @property
    def why(self) -> str:
        """One sentence on the verdict."""
        percent = (self.factor - 1.0) * 100.0
        if self.suspect:
            return (
                f"the scans fit the plan best scaled by {self.factor:.4f} ({percent:+.1f} %) over {self.fits} fits: "
                f"its scale looks wrong; fix it with plan.scaled({self.factor:.4f}) or a corrected resolution "
                f"(planicp.estimate_scale measures it)"
            )
        return f"the scans fit the plan at scale {self.factor:.4f} ({percent:+.1f} %) over {self.fits} fits"


@dataclass
class ScaleMonitor:
    """The running state `ScaleRule` is applied to, for one plan."""

    plan: PlanMap
    rule: ScaleRule = field(default_factory=ScaleRule)
    errors: deque[float] = field(default_factory=deque)
    observed: int = 0
    warned: bool = False
    last: ScaleEstimate | None = None
    _lookup: WallLookup | None = None

    def __post_init__(self) -> None:
        if self.rule.enabled:
            self._lookup = WallLookup(self.plan)

    def observe(self, points: NDArray[np.float64], fit_pose: Pose) -> ScaleEstimate | None:
        """Takes a fit near the prediction: its scan (base frame) and ICP's pose (T_map_base).
        Returns the estimate so far (None before `min_fits` fits); warns once
        (`PlanScaleWarning`) when the plan becomes suspect."""
        rule = self.rule
        if self._lookup is None or not rule.enabled:
            return None
        self.observed += 1
        if (self.observed - 1) % rule.every == 0:
            fit = scale_fit(self._lookup, points, fit_pose, rule.max_distance)
            if fit is not None:
                # A scale that explains no more of the scan than the rigid fit does is no evidence
                # of one: the simpler model stands (a scan of clutter fits some scale of its own).
                self.errors.append(fit.error if fit.explained - fit.explained_rigid >= rule.min_gain else 0.0)
                while len(self.errors) > rule.window:
                    self.errors.popleft()
                self.last = self._judge()
        if self.last is not None and self.last.suspect and not self.warned:
            self.warned = True
            warnings.warn(PlanScaleWarning(self.last.why), stacklevel=3)
        return self.last

    def _judge(self) -> ScaleEstimate | None:
        rule = self.rule
        n = len(self.errors)
        if n < rule.min_fits:
            return None
        errors = np.fromiter(self.errors, dtype=np.float64, count=n)
        median = float(np.median(errors))
        spread = 1.4826 * float(np.median(np.abs(errors - median)))
        side = math.copysign(1.0, median)
        agreement = float(np.mean(side * errors > rule.tolerance / 2.0))
        suspect = abs(median) >= rule.tolerance and agreement >= rule.agreement
        factor = 1.0 / (1.0 + median)
        std = factor * factor * spread / math.sqrt(n)
        return ScaleEstimate(factor, std, n, agreement, suspect)
