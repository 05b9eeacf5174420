"""Small PDF files the tests write themselves (`write_pdf`), for the PDF readers' tests."""

from __future__ import annotations

from pathlib import Path


def write_pdf(
    path: Path, content: str, *, layers: tuple[str, ...] = (), size: tuple[int, int] = (400, 320), rotate: int = 0
) -> Path:
    """A one-page PDF with `content` as its content stream, Helvetica as /F1 (WinAnsi: "²" and
    "ft²" are text), and optional content groups `layers` named /OC0, /OC1, ... in the page's
    properties."""
    first_layer = 6
    refs = " ".join(f"{first_layer + i} 0 R" for i in range(len(layers)))
    props = " ".join(f"/OC{i} {first_layer + i} 0 R" for i in range(len(layers)))
    oc = f" /OCProperties << /OCGs [{refs}] /D << /ON [{refs}] >> >>" if layers else ""
    stream = content.encode("latin-1")
    objects = [
        f"<< /Type /Catalog /Pages 2 0 R{oc} >>".encode(),
        b"<< /Type /Pages /Kids [3 0 R] /Count 1 >>",
        (
            f"<< /Type /Page /Parent 2 0 R /MediaBox [0 0 {size[0]} {size[1]}] /Rotate {rotate} /Contents 4 0 R "
            f"/Resources << /Font << /F1 5 0 R >> /Properties << {props} >> >> >>"
        ).encode(),
        f"<< /Length {len(stream)} >>\nstream\n".encode() + stream + b"\nendstream",
        b"<< /Type /Font /Subtype /Type1 /BaseFont /Helvetica /Encoding /WinAnsiEncoding >>",
        *[f"<< /Type /OCG /Name ({name}) >>".encode() for name in layers],
    ]
    out = bytearray(b"%PDF-1.5\n")
    offsets = []
    for number, body in enumerate(objects, start=1):
        offsets.append(len(out))
        out += f"{number} 0 obj\n".encode() + body + b"\nendobj\n"
    xref = len(out)
    out += f"xref\n0 {len(objects) + 1}\n0000000000 65535 f \n".encode()
    out += b"".join(f"{o:010d} 00000 n \n".encode() for o in offsets)
    out += f"trailer\n<< /Size {len(objects) + 1} /Root 1 0 R >>\nstartxref\n{xref}\n%%EOF\n".encode()
    path.write_bytes(bytes(out))
    return path
