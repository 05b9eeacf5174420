"""What kind of drawing a plan file is, from its suffix and its first bytes, and what reading it needs.

`plan_format` tells a plan loader which reader to use before any reader opens the file, so that a
PDF, SVG or IFC file is read by its own reader, or refused naming the optional extra that reads it
(`missing_extra`), and never handed to the image decoder (which could only say it "could not be
read as an image"). Formats planicp does not read at all (DWG, RVT, SKP) are refused with what to
export instead (`unsupported_format`).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

__all__ = ["EXTRAS", "missing_extra", "plan_format", "unsupported_format"]

EXTRAS: dict[str, tuple[str, tuple[str, ...]]] = {
    # format -> (the optional extra that reads it, the importable modules it installs)
    "dxf": ("cad", ("ezdxf",)),
    "pdf": ("pdf", ("pdfminer", "pypdfium2")),
    "svg": ("svg", ("svgelements",)),
}
"""The optional extra each drawing format needs (IFC needs none: planicp reads it itself)."""

_SUFFIXES = {
    ".yaml": "ros_map",
    ".yml": "ros_map",
    ".json": "house_expo",
    ".dxf": "dxf",
    ".pdf": "pdf",
    ".svg": "svg",
    ".ifc": "ifc",
    ".dwg": "dwg",
    ".ifczip": "ifczip",
    ".ifcxml": "ifcxml",
    ".svgz": "svgz",
    ".rvt": "rvt",
    ".skp": "skp",
}

_UNSUPPORTED = {
    "dwg": "DWG drawings are not read: save the drawing as DXF in the CAD program (or convert it with "
    "the ODA File Converter) and give the .dxf",
    "ifczip": "zipped IFC is not read: unzip it and give the .ifc inside",
    "ifcxml": "IFC-XML is not read: export the model as IFC (STEP, .ifc)",
    "svgz": "compressed SVG is not read: decompress it (gunzip -S .svgz) and give the .svg",
    "rvt": "Revit models are not read: export the floor as IFC or DXF from Revit",
    "skp": "SketchUp models are not read: export the floor as IFC or DXF from SketchUp",
}


def plan_format(path: Path) -> str:
    """The kind of plan `path` holds: "ros_map", "house_expo", "dxf", "pdf", "svg", "ifc", "image",
    or one planicp refuses ("dwg", "ifczip", "ifcxml", "svgz", "rvt", "skp").

    The first bytes decide for PDF, SVG, IFC, DXF and DWG files whatever their suffix (a PDF saved
    as `plan.png` is still a PDF); otherwise the suffix does, and anything else is an image. A file
    that cannot be opened is left to the reader (which names the problem).
    """
    sniffed = _sniff(path)
    if sniffed is not None:
        return sniffed
    return _SUFFIXES.get(path.suffix.lower(), "image")


def _sniff(path: Path) -> str | None:
    try:
        if not path.is_file():  # a folder, a device, a pipe (whose opening would wait for a writer)
            return None
        with open(path, "rb") as f:
            head = f.read(4096)
    except OSError:
        return None
    if head.startswith(b"%PDF-"):
        return "pdf"
    if head.startswith(b"\x1f\x8b") and path.suffix.lower() == ".svgz":
        return "svgz"
    if head.lstrip(b"\xef\xbb\xbf \t\r\n").startswith(b"ISO-10303-21"):
        return "ifc"
    if head[:4] == b"AC10" and head[4:6].isdigit():
        return "dwg"
    text = head.lstrip(b"\xef\xbb\xbf \t\r\n")
    if text.startswith((b"<?xml", b"<svg", b"<!DOCTYPE svg", b"<!--")) and b"<svg" in head:
        return "svg"
    if text.startswith(b"0") and b"SECTION" in head[:200] and path.suffix.lower() not in (".yaml", ".yml", ".json"):
        return "dxf"
    return None


def unsupported_format(kind: str, path: Path) -> str | None:
    """The refusal for a format planicp does not read ("dwg", ...), naming `path` and what to give
    instead; None for a format it reads."""
    reason = _UNSUPPORTED.get(kind)
    return None if reason is None else f"plan {path}: {reason}"


def missing_extra(kind: str, path: Path | None = None) -> str | None:
    """The refusal when the optional extra that reads `kind` is not installed (naming the extra to
    install), or None when it is (or the format needs none)."""
    if kind not in EXTRAS:
        return None
    extra, modules = EXTRAS[kind]
    missing = [m for m in modules if importlib.util.find_spec(m) is None]
    if not missing:
        return None
    what = f"{kind.upper()} plan {path}" if path is not None else f"{kind.upper()} plans"
    return (
        f"reading {what} needs the optional extra {extra!r} ({', '.join(missing)} not installed): "
        f"pip install 'planicp[{extra}]'"
    )
