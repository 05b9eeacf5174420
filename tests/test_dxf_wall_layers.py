"""A DXF drawing's walls by default: the layers named as walls by CAD conventions, the building's
shell around them on a layer whose name says nothing, and every layer shown when none is named.
The drawings are written here with ezdxf, metres."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from planicp.cli import main as cli_main
from planicp.plans.dxf_wall_layers import not_shell, wall_layer

ezdxf = pytest.importorskip("ezdxf")


def _rect(
    msp: object, x0: float, y0: float, x1: float, y1: float, layer: str, gap: tuple[float, float] | None = None
) -> None:
    """A rectangle of LINEs on `layer`; `gap` (x from, x to) leaves an opening in its bottom side."""
    bottom = [((x0, y0), (x1, y0))] if gap is None else [((x0, y0), (gap[0], y0)), ((gap[1], y0), (x1, y0))]
    for a, b in [*bottom, ((x1, y0), (x1, y1)), ((x1, y1), (x0, y1)), ((x0, y1), (x0, y0))]:
        msp.add_line(a, b, dxfattribs={"layer": layer})  # type: ignore[attr-defined]


def _house(tmp_path: Path, wall_layer_name: str, shell_layer: str, *, beams_linetype: str = "DASHED") -> Path:
    """A 10 x 6 m building: its outline (a 1 m door gap in the south side) on `shell_layer`, two
    inner walls (double lines 0.1 m apart, running up to the outline) on `wall_layer_name`, a table
    among them on "Tisch", a steel beam over the whole length on "Stahltraeger" (dashed: above the
    cut), and a plot frame 2 m around the building on "Layer1"."""
    doc = ezdxf.new(setup=True)  # with CAD's standard linetypes
    doc.header["$INSUNITS"] = 6
    msp = doc.modelspace()
    doc.layers.add(wall_layer_name)
    doc.layers.add(shell_layer)
    doc.layers.add("Tisch")
    doc.layers.add("Stahltraeger", linetype=beams_linetype)
    doc.layers.add("Layer1")
    _rect(msp, 0, 0, 10, 6, shell_layer, gap=(2, 3))
    for x in (4.0, 7.0):
        msp.add_line((x, 0), (x, 6), dxfattribs={"layer": wall_layer_name})
        msp.add_line((x + 0.1, 0), (x + 0.1, 6), dxfattribs={"layer": wall_layer_name})
    _rect(msp, 5, 2, 6.5, 3, "Tisch")
    _rect(msp, -0.5, 2.9, 10.5, 3.1, "Stahltraeger")
    _rect(msp, -2, -2, 12, 8, "Layer1")
    path = tmp_path / "house.dxf"
    doc.saveas(path)
    return path


@pytest.mark.parametrize(
    "name",
    ["A-WALL", "A-WALL-FULL", "I-WALL", "Walls", "Drywall", "Wand (neu)", "Außenwand", "Innenwände", "Mauerwerk",
     "MUR", "murs porteurs", "Muro", "pareti", "Paredes", "Väggar", "muren", "Ściany", "stěna", "A--21----",
     "A-22", "EF_25_10"],
)  # fmt: skip
def test_wall_layer_names_of_cad_conventions_and_languages(name: str) -> None:
    assert wall_layer(name)


@pytest.mark.parametrize(
    "name",
    ["0", "Base", "Outline", "A-WALL-PATT", "A-WALL-IDEN", "A-WALL-DEMO", "Wand Text", "Wandschrank", "A-FURN",
     "Shelves", "Stahltraeger", "Doors", "A-DOOR", "Sand", "Murmel", "A-23", "A-2100"],
)  # fmt: skip
def test_names_that_are_not_wall_layers(name: str) -> None:
    assert not wall_layer(name)


def test_names_that_enclose_walls_without_being_their_shell() -> None:
    assert all(not_shell(n) for n in ("A-GRID", "Achsen", "Rooms", "A-AREA", "Rahmen", "Title block", "Möbel"))
    assert not any(not_shell(n) for n in ("0", "Base", "Outline", "Layer1", "Bestand"))


def test_wall_layers_and_their_shell_read_by_default_the_rest_left_out_and_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from planicp.plans.dxf_plan import dxf_layers, dxf_walls

    path = _house(tmp_path, "Wand", "Base")
    walls = dxf_walls(path)
    assert walls.layers == ("Base", "Wand")
    # The shell with its door gap (9 m + 1 m + ... = 31 m) and the four inner wall lines (24 m).
    lengths = np.hypot(*(walls.segments[:, 1] - walls.segments[:, 0]).T)
    assert lengths.sum() == pytest.approx(31.0 + 24.0)
    assert walls.notes[3] == (
        "layers: named as walls: Wand; the shell around them: Base; left out, not named as walls: Layer1, "
        "Stahltraeger, Tisch (read them by naming every wall layer with --layer, layers=[...])"
    )
    assert "Tisch: not named as walls" in walls.skipped_layers
    states = {layer.name: (layer.state, layer.read_by_default) for layer in dxf_layers(path)}
    assert states["Base"] == ("on, the shell around the walls", True)
    assert states["Wand"] == ("on, named as walls", True)
    assert states["Layer1"] == ("on, not named as walls", False)
    assert cli_main(["plan", str(path), "--list-layers"]) == 0
    assert "Tisch: on, not named as walls; 4 LINE (not read unless named with --layer)" in capsys.readouterr().out
    # Named explicitly, every layer asked for is read, and nothing else.
    assert dxf_walls(path, ["Wand", "Tisch"]).layers == ("Tisch", "Wand")


def test_a_shell_is_continuous_spans_the_walls_and_meets_them(tmp_path: Path) -> None:
    from planicp.plans.dxf_plan import dxf_walls

    # The beam drawn solid does not span the walls (it crosses them): still left out. Two sides of
    # the building on "Layer3" span the walls and meet them, but enclose nothing: left out.
    path = _house(tmp_path, "A-WALL", "Outline", beams_linetype="CONTINUOUS")
    doc = ezdxf.readfile(path)
    doc.layers.add("Layer3")
    doc.modelspace().add_line((0, 0), (10, 0), dxfattribs={"layer": "Layer3"})
    doc.modelspace().add_line((10, 0), (10, 6), dxfattribs={"layer": "Layer3"})
    # Shelves between the inner walls, against them ("Regal": a name the rules do not know): they
    # meet the walls and enclose them within a cell, but stand among them, not around: left out.
    doc.layers.add("Regal")
    _rect(doc.modelspace(), 4.1, 0, 7, 6, "Regal")
    doc.saveas(path)
    assert dxf_walls(path).layers == ("A-WALL", "Outline")
    # The outline drawn dashed (above the cut) is no shell; the frame around encloses the walls
    # and spans them but meets none of them: only the named walls are read.
    path = _house(tmp_path, "A-WALL", "Umriss")
    doc = ezdxf.readfile(path)
    doc.layers.get("Umriss").dxf.linetype = "DASHED"
    doc.saveas(path)
    assert dxf_walls(path).layers == ("A-WALL",)


def test_no_layer_named_as_walls_reads_every_layer_shown_and_says_so(tmp_path: Path) -> None:
    from planicp.plans.dxf_plan import dxf_walls

    path = _house(tmp_path, "Layer2", "Base")
    walls = dxf_walls(path)
    assert walls.layers == ("Base", "Layer1", "Layer2", "Stahltraeger", "Tisch")
    assert walls.notes[3].startswith("layers: none is named as walls (wall, A-WALL, Wand, mur, muro,")
    assert not any("not named as walls" in s for s in walls.skipped_layers)


def test_layers_are_listed_even_when_the_walls_cannot_be_read(tmp_path: Path) -> None:
    from planicp.plans.dxf_plan import dxf_layers, dxf_walls

    path = _house(tmp_path, "Wand", "Base")
    doc = ezdxf.readfile(path)
    doc.header["$INSUNITS"] = 99  # no unit DXF defines
    doc.saveas(path)
    with pytest.raises(ValueError, match=r"unknown drawing units \$INSUNITS = 99"):
        dxf_walls(path)
    listed = {layer.name: (layer.state, layer.read_by_default) for layer in dxf_layers(path)}
    assert listed["Base"] == ("on", True) and listed["Stahltraeger"] == ("on", True)


def test_a_non_finite_coordinate_is_refused_naming_the_file(tmp_path: Path) -> None:
    from planicp.plans.dxf_plan import dxf_walls

    path = _house(tmp_path, "Wand", "Base")
    doc = ezdxf.readfile(path)
    doc.modelspace().add_line((0, 0), (1e308, 0), dxfattribs={"layer": "Wand"})
    doc.saveas(path)
    text = path.read_text().replace("1e+308", "inf")
    path.write_text(text)
    with pytest.raises(ValueError, match=r"house\.dxf.*non-finite"):
        dxf_walls(path)


def test_a_shell_candidate_with_a_non_finite_coordinate_is_left_out(tmp_path: Path) -> None:
    from planicp.plans.dxf_plan import dxf_walls

    path = _house(tmp_path, "Wand", "Base")
    doc = ezdxf.readfile(path)
    doc.modelspace().add_line((0, 0), (1e308, 6), dxfattribs={"layer": "Base"})
    doc.saveas(path)
    path.write_text(path.read_text().replace("1e+308", "inf"))
    walls = dxf_walls(path)
    assert walls.layers == ("Wand",) and "Base: not named as walls" in walls.skipped_layers
    with pytest.raises(ValueError, match=r"house\.dxf.*non-finite"):
        dxf_walls(path, ["Wand", "Base"])
