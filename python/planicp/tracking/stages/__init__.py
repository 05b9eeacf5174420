"""The stages of one `Localizer.update`, in the order it runs them, one module each.

Each stage is a function that takes the scan, the decisions of the stages before it and the
`Rules` of this update (`rules`), and returns its own decision (`planicp.tracking.decisions`):

1. `predict` -> `Prediction` (`prediction`)
2. `fit_from_prediction` -> `FitDecision` (`fit`)
3. `confirm_pending` -> `PendingDecision` (`pending`)
4. `search_near_prediction` -> `SearchDecision` (`search`)
5. `judge_score` -> `ScoreDecision` (`score`)
6. `correct` -> `Correction` (`correction`)
7. `weigh_left_place` -> `LeftPlaceDecision` (`left_place`)
8. `judge_lost` -> `LostDecision` (`lost`)
9. `recover` -> `RecoveryDecision` (`recovery_step`)
10. `keep_records` -> `Bookkeeping` (`bookkeeping`)

The stages change no state of the `Localizer` itself (pose, covariance, last odometry, anchor,
pending place, place left behind: `update` writes those from the decisions); the lost stage updates the
`LostDetector` and the recovery and bookkeeping stages the `Recovery` they are given, which
hold the running state of their rules. The `Localizer` documentation explains the rules; the
helpers here say what each step does.
"""

from __future__ import annotations

from .bookkeeping import keep_records
from .correction import correct, finite_or
from .fit import fit_from_prediction, occupied_cells, poor_fit
from .left_place import weigh_left_place
from .lost import judge_lost
from .pending import confirm_pending, spread_over_pending
from .prediction import predict
from .recovery_step import recover
from .rules import Rules
from .score import judge_score, scan_score
from .search import search_cause, search_near_prediction

__all__ = [
    "Rules",
    "confirm_pending",
    "correct",
    "finite_or",
    "fit_from_prediction",
    "judge_lost",
    "judge_score",
    "keep_records",
    "occupied_cells",
    "poor_fit",
    "predict",
    "recover",
    "scan_score",
    "search_cause",
    "search_near_prediction",
    "spread_over_pending",
    "weigh_left_place",
]
