"""The text written on a raster drawing, read by OCR: each line of words with where it is.

Room labels ("BEDROOM", `11'7" x 15'7"`, "13 m²") are what `label_scale` needs to find a drawing's
scale. They are read with RapidOCR (`rapidocr`, Apache-2.0): PaddleOCR's PP-OCR text detector and
recogniser as ONNX models shipped inside its wheel, run by ONNX Runtime (MIT), on the CPU, offline,
nothing downloaded at run time. planicp does not install them, not even as an optional extra:
RapidOCR depends on Shapely, whose wheels bundle GEOS (LGPL-2.1), and the project's dependencies
are permissive only (docs/plans.md, Licences). A user installs them knowingly
(`OCR_REQUIREMENTS`); without them `drawing_text` raises an ImportError saying how, and
`ocr_available()` says so beforehand.

OCR confuses an inch mark after a number with a degree sign or an asterisk (`11'7° x 15'7"`,
`10'1* x 10'8"`): `clean_ocr_text` puts the inch mark back where a foot mark precedes it.

Positions are pixels of the image as given, (column, row) from its top-left corner: the frame
`label_scale` takes.
"""

from __future__ import annotations

import importlib.util
import logging
import re
from collections.abc import Sequence
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .label_scale import RoomLabel

__all__ = ["OCR_INSTALL", "OCR_MISSING", "OCR_REQUIREMENTS", "clean_ocr_text", "drawing_text", "ocr_available"]

OCR_REQUIREMENTS = ("rapidocr>=3.10,<4", "onnxruntime>=1.17")
"""What reads a drawing's text, installed by hand (CI installs them from here: .ci/run). RapidOCR 3
uses opencv-python-headless, the OpenCV planicp has; rapidocr_onnxruntime 1.x wanted opencv-python,
a second OpenCV in the same cv2 folder."""

OCR_INSTALL = "pip install " + " ".join(f"'{r}'" for r in OCR_REQUIREMENTS)
"""The command that installs `OCR_REQUIREMENTS`."""

_OCR_MODULES = ("rapidocr", "onnxruntime")

OCR_MISSING = (
    "reading a drawing's text needs RapidOCR (Apache-2.0) and ONNX Runtime (MIT), which planicp does not "
    f"install itself (RapidOCR depends on Shapely, whose wheels bundle GEOS, LGPL-2.1): {OCR_INSTALL}"
)
"""The refusal when the OCR is not installed."""

MIN_CONFIDENCE = 0.5
"""Lines the recogniser is less sure of than this (0..1) are left out."""

# An inch mark misread after a number, in a text that has a foot mark: 11'7° -> 11'7", 10'1* -> 10'1"
_MISREAD_INCH = re.compile(r"(['’′]\s?)(\d+(?:\s+\d+/\d+)?)\s*[°*º˚]")


def ocr_available() -> bool:
    """True when RapidOCR and ONNX Runtime are installed (`OCR_REQUIREMENTS`)."""
    return all(importlib.util.find_spec(module) is not None for module in _OCR_MODULES)


def clean_ocr_text(text: str) -> str:
    """`text` with OCR's usual misreadings of room labels undone: an inch mark read as a degree
    sign or an asterisk after the inches of a feet-and-inches length (`11'7° x 15'7"` becomes
    `11'7" x 15'7"`). Everything else is kept as read."""
    return _MISREAD_INCH.sub(lambda m: m.group(1) + m.group(2) + '"', text.strip())


@lru_cache(maxsize=1)
def _engine() -> Any:
    if not ocr_available():
        raise ImportError(OCR_MISSING)
    from rapidocr import RapidOCR

    # Room labels are written upright or turned a quarter: the 180-degree classifier is not needed. Its
    # log says "The text detection result is empty" as a warning: a drawing without text is no error.
    engine = RapidOCR(params={"Global.log_level": "error", "Global.use_cls": False})
    logging.getLogger("RapidOCR").setLevel(logging.ERROR)
    return engine


def drawing_text(image: NDArray[np.uint8], min_confidence: float = MIN_CONFIDENCE) -> list[RoomLabel]:
    """The lines of text OCR reads on a drawing, each as a `RoomLabel`: its words (cleaned by
    `clean_ocr_text`), its centre and its box, in pixels of `image` (column, row from the top-left).

    Args:
        image: (H, W) grey or (H, W, 3) RGB, 8-bit.
        min_confidence: lines recognised with less confidence (0..1) are left out.

    Raises:
        ImportError: RapidOCR or ONNX Runtime is not installed (the message says how to install them).
        ValueError: an image that is not 8-bit grey or RGB.
    """
    engine = _engine()
    arr = np.asarray(image)
    if arr.dtype != np.uint8 or not (arr.ndim == 2 or (arr.ndim == 3 and arr.shape[2] == 3)):
        raise ValueError(f"drawing_text needs an 8-bit (H, W) grey or (H, W, 3) RGB image, got {arr.dtype} {arr.shape}")
    bgr = np.repeat(arr[:, :, None], 3, axis=2) if arr.ndim == 2 else np.ascontiguousarray(arr[:, :, ::-1])
    result = engine(bgr)
    boxes: Sequence[Any] = [] if result.boxes is None else result.boxes
    labels: list[RoomLabel] = []
    for box, text, score in zip(boxes, result.txts or (), result.scores or ()):
        if float(score) < min_confidence or not str(text).strip():
            continue
        corners = np.asarray(box, dtype=np.float64).reshape(-1, 2)
        x0, y0 = corners.min(axis=0)
        x1, y1 = corners.max(axis=0)
        labels.append(
            RoomLabel(
                clean_ocr_text(str(text)),
                float(0.5 * (x0 + x1)),
                float(0.5 * (y0 + y1)),
                (float(x0), float(y0), float(x1), float(y1)),
            )
        )
    return labels
