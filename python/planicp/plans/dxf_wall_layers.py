"""Which layers of a DXF drawing are its walls, when the user names none: CAD layer conventions,
and the building's shell around them.

CAD drawings put walls on layers, and the layer names follow conventions a user expects a reader
to know (`wall_layer`):

* the words for wall in the languages CAD users draw in, alone or in a compound, as a word of the
  layer's name: wall (A-WALL of the AIA / US National CAD Standard, Walls, Drywall), Wand and
  Wände (Außenwand, Wand (neu)), Mauer, mur, muro, parete, pared, parede, vägg, væg, vegg, muur,
  ściana, stěna, seinä, duvar, стена;
* the element codes of ISO 13567 layer names in the CI/SfB classification (21 external walls, 22
  internal walls, as in "A--21----" or "A221") and of Uniclass 2015 ("EF_25", "Ss_25": walls);
* but not a wall layer's annotation, hatching, walls above the cut or demolished walls, named by
  the AIA modifiers PATT, IDEN, HEAD, OVHD, DEMO (and hatch, text, dims, ...).

When at least one layer shown is named as walls, the walls are those layers, plus each layer that
is the building's SHELL around them (`shell_layers`): many drawings keep the outer outline of the
building on a layer whose name says nothing ("0", "Base", "Outline"), and a user expects the outer
walls in the plan. A layer is a shell when

* its name is not that of something else known to enclose walls: grid and axes, rooms, spaces
  and areas, a drawing frame or title block, furniture or fixtures (`not_shell`);
* it is drawn in a continuous linetype (CAD draws what is above the cut, hidden, or an axis
  dashed: beams overhead, axes);
* its line work spans the named walls' extent (its bounding box holds theirs, within
  `SHELL_TOUCH`): furniture and fixtures stand among the walls, not around them;
* its line work, once gaps up to `SHELL_GAP` (doors in the outer wall) are closed (the line
  work grown by half that, the outside found, and grown back), encloses at least
  `SHELL_ENCLOSED` of the named walls' line work;
* and the named walls meet it: at least `SHELL_TOUCHES` of their vertices lie on its line work
  (within `SHELL_TOUCH` metres): inner walls run up to the outer ones, while a drawing frame or a
  plot border stands apart.

Every other layer shown is left out and named in the notes, with how to read it (`--layer`). When
no layer is named as walls, every layer shown is read, as before, and the notes say so.
"""

from __future__ import annotations

import re

import numpy as np
from numpy.typing import NDArray

__all__ = ["not_shell", "shell_layers", "wall_layer"]

_WALL_WORD = re.compile(
    r"\w*walls?|\w*w(?:and|ände|aende)|mauer\w*|\w*mauer|murs?|muro?s?|muri|paret[ei]|pared(?:es)?|paredes?"
    r"|v[äa]gg(?:ar)?|v(?:æ|ae)gg?e?|vegg(?:er)?|muur|muren|[śs]cian[ayę]|st[ěe]n[ayu]|sein[äa]t?|duvar(?:lar)?"
    r"|стен[аыу]",
    re.IGNORECASE,
)
"""A word of a layer name that names walls (the whole word, a compound ending in -wall, -wand or
-mauer included)."""

_WALL_CODE = re.compile(r"^[A-Z][-_]{0,2}2[12][0-9]?(?![0-9])|(?:^|[-_ ])(?:EF|Ss)_25(?![0-9])", re.IGNORECASE)
"""ISO 13567 / CI/SfB element codes 21 and 22 (external and internal walls) after the agent
letter, and Uniclass 2015's walls (EF_25, Ss_25)."""

_NOT_WALLS = re.compile(
    r"patt|hatch|schraff\w*|iden|text|txt|dims?|dimensions?|bema\w*|cote|head|ovhd|demo|abbruch|demol\w*", re.IGNORECASE
)
"""Words that make a wall layer's name that of something else: its hatching, tags, text,
dimensions, walls above the cut (HEAD, OVHD), demolished walls."""

_NOT_SHELL = re.compile(
    r"grid|axis|axes|achsen?|raster|room|rooms|space|spaces|area|areas|zone|raum|räume|raeume|fläche\w*|flaeche\w*"
    r"|pi[eè]ce|local|frame|border|rahmen|title\w*|titel\w*|plankopf|cartouche|viewport|vport|furn\w*|m[öo]bel"
    r"|moebel|fixt\w*|equip\w*|text|dims?|hatch|door|window|fenster|t(?:ü|ue)ren?",
    re.IGNORECASE,
)
"""Words of layers that may enclose walls without being them."""

_WORD = re.compile(r"[^\W\d_]+", re.UNICODE)

SHELL_GAP = 1.5
"""Widest gap in a shell's outline closed before asking what it encloses, metres (a door)."""

SHELL_ENCLOSED = 0.9
"""Share of the named walls' line work a shell encloses."""

SHELL_TOUCH = 0.02
"""Distance of a named wall's vertex to a shell's line work for it to meet the shell, metres."""

SHELL_TOUCHES = 2
"""How many of the named walls' vertices meet a shell."""

_SHELL_GRID_CELLS = 2000
"""Most cells along the longer side of the raster the shell test draws on (each at least a 20th of
`SHELL_GAP`, 7.5 cm)."""


def _words(name: str) -> list[str]:
    return _WORD.findall(name)


def wall_layer(name: str) -> bool:
    """Whether a layer's name says it holds walls (see the module's description)."""
    words = _words(name)
    if any(_NOT_WALLS.fullmatch(w) for w in words):
        return False
    return any(_WALL_WORD.fullmatch(w) for w in words) or bool(_WALL_CODE.search(name))


def not_shell(name: str) -> bool:
    """Whether a layer's name says it holds something that may enclose walls without being them
    (grid, rooms, a frame, furniture, annotation, doors and windows)."""
    return any(_NOT_SHELL.fullmatch(w) for w in _words(name))


def continuous(linetype: str) -> bool:
    """Whether a linetype name draws solid lines (CONTINUOUS, BYLAYER, BYBLOCK, none)."""
    return linetype.strip().casefold() in ("", "continuous", "bylayer", "byblock")


def shell_layers(
    candidates: dict[str, list[NDArray[np.float64]]], walls: list[NDArray[np.float64]], metres_per_unit: float
) -> list[str]:
    """The layers among `candidates` that are the building's shell around `walls`.

    Args:
        candidates: layer name -> its chains ((K >= 2, 2) vertices, drawing units); only layers
            already found eligible by name and linetype.
        walls: the chains of the layers named as walls, drawing units.
        metres_per_unit: the drawing's unit, metres.

    Returns:
        The names of the shells, sorted (see the module's description for the test).
    """
    import cv2

    if not walls or not candidates:
        return []
    wall_pts = np.concatenate(walls)
    if not np.isfinite(wall_pts).all():
        return []  # refused by the reader, naming the file
    found = []
    for name, chains in sorted(candidates.items()):
        if not chains:
            continue
        pts = np.concatenate(chains)
        if not np.isfinite(pts).all():
            continue
        touch = SHELL_TOUCH / metres_per_unit
        if (pts.min(axis=0) > wall_pts.min(axis=0) + touch).any() or (
            pts.max(axis=0) < wall_pts.max(axis=0) - touch
        ).any():
            continue  # it does not span the walls' extent: something beside or among them
        lo = np.minimum(pts.min(axis=0), wall_pts.min(axis=0))
        hi = np.maximum(pts.max(axis=0), wall_pts.max(axis=0))
        cell = max(float((hi - lo).max()) / _SHELL_GRID_CELLS, SHELL_GAP / 20.0 / metres_per_unit)
        gap = SHELL_GAP / metres_per_unit
        pad = int(np.ceil(gap / cell)) + 2
        lo = lo - pad * cell
        w, h = (np.ceil((hi - lo) / cell).astype(np.int64) + pad + 1).tolist()
        mask = np.zeros((h, w), np.uint8)
        for chain in chains:
            q = np.round((chain - lo) / cell).astype(np.int32)
            cv2.polylines(mask, [q.reshape(-1, 1, 2)], False, 1, 1)
        radius = max(1, int(np.ceil(gap / 2.0 / cell)))
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1, 2 * radius + 1))
        band = cv2.dilate(mask, kernel)  # the line work grown by half the widest gap: gaps closed
        outside = band.copy()
        cv2.floodFill(outside, np.zeros((h + 2, w + 2), np.uint8), (0, 0), 2)
        # Outside grown back by as much (less 2 cells, so that the line work itself is inside).
        back = max(0, radius - 2)
        grown = cv2.dilate(
            (outside == 2).astype(np.uint8), cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * back + 1, 2 * back + 1))
        )
        enclosed = grown == 0
        samples = []
        for chain in walls:
            for a, b in zip(chain[:-1], chain[1:]):
                n = max(1, int(np.ceil(float(np.hypot(*(b - a))) / cell)))
                samples.append(a + np.linspace(0.0, 1.0, n + 1)[:, None] * (b - a))
        s = np.round((np.concatenate(samples) - lo) / cell).astype(np.int64)
        if float(enclosed[s[:, 1], s[:, 0]].mean()) < SHELL_ENCLOSED:
            continue
        # Only the vertices in or next to a cell of its line work can meet it (cells >= 7.5 cm).
        v = np.round((wall_pts - lo) / cell).astype(np.int64)
        near = cv2.dilate(mask, np.ones((3, 3), np.uint8))[v[:, 1], v[:, 0]] > 0
        if _touches(chains, wall_pts[near], SHELL_TOUCH / metres_per_unit) >= SHELL_TOUCHES:
            found.append(name)
    return found


def _touches(chains: list[NDArray[np.float64]], points: NDArray[np.float64], tol: float) -> int:
    """How many of `points` lie within `tol` of a segment of `chains` (counted until
    `SHELL_TOUCHES`)."""
    a = np.concatenate([c[:-1] for c in chains])
    b = np.concatenate([c[1:] for c in chains])
    ab = b - a
    length2 = np.maximum((ab**2).sum(axis=1), 1e-300)
    count = 0
    for start in range(0, len(points), 256):
        if count >= SHELL_TOUCHES:
            break
        p = points[start : start + 256, None, :]  # (P, 1, 2) against (S, 2)
        t = np.clip(((p - a) * ab).sum(axis=2) / length2, 0.0, 1.0)
        d = np.hypot(*(a + t[..., None] * ab - p).transpose(2, 0, 1))
        count += int((d.min(axis=1) <= tol).sum())
    return count
