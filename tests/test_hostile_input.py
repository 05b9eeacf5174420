"""Files built to exhaust memory or to confuse a reader: each is refused with a short message
naming the file, in bounded memory and time (issue: hostile input and faults)."""

from __future__ import annotations

import re
import resource
import subprocess
import sys
import textwrap
from pathlib import Path

import cv2
import numpy as np
import pytest

import carmen_excerpt
from planicp import EnhancedOccupancyGrid, PlanMap
from planicp._core import PlanicpError
from planicp._validation import brief
from planicp.cli import main as cli_main
from planicp.evaluation.log_evaluation import plan_from_scans
from planicp.io import read_carmen
from planicp.io.yaml_documents import MAX_EXPANDED_VALUES, expanded_size, load_yaml
from planicp.plans.default_plan import default_plan_path, load_default_plan
from planicp.sweep import StudyError, load_study

MAP_KEYS = "resolution: 0.05\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n"


def alias_bomb(levels: int = 9) -> str:
    """YAML anchors l0..l{levels-1}, each a list of nine aliases of the one before: 9^levels
    values once expanded, in a few hundred bytes."""
    lines = ['l0: &l0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for i in range(1, levels):
        lines.append(f"l{i}: &l{i} [" + ", ".join([f"*l{i - 1}"] * 9) + "]")
    return "\n".join(lines) + "\n"


def a_map_image(folder: Path) -> None:
    cv2.imwrite(str(folder / "m.pgm"), np.pad(np.zeros((10, 10), np.uint8), 5, constant_values=254))


@pytest.mark.parametrize("key", ["origin", "resolution", "negate", "mode", "image"])
def test_a_ros_map_whose_aliases_expand_to_billions_is_refused_in_bounded_memory(tmp_path: Path, key: str) -> None:
    """A 437-byte map_server YAML with nested aliases in one value reached 4.7 GB (51 s) when that
    value was turned into text for an error message. Run in its own process under a 1 GiB address
    space: it is refused at once."""
    a_map_image(tmp_path)
    values = {"image": "m.pgm", "resolution": "0.05", "origin": "[0, 0, 0]", "negate": "0", "mode": "trinary"}
    values[key] = "*l8"
    text = (
        alias_bomb() + "".join(f"{k}: {v}\n" for k, v in values.items()) + "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    (tmp_path / "bomb.yaml").write_text(text)
    assert len(text) < 1000
    code = f"""
        import resource
        resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30))
        import planicp
        try:
            planicp.PlanMap.from_ros_map({str(tmp_path / "bomb.yaml")!r})
        except ValueError as exc:
            print("refused:", exc)
    """
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "refused: ROS map" in done.stdout and "aliases" in done.stdout and len(done.stdout) < 400, done.stdout


def test_a_study_whose_name_is_an_alias_bomb_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "study.yaml"
    path.write_text(alias_bomb() + "name: *l8\n")
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(StudyError, match=r"study .*study\.yaml expands to more than 100000 values"):
        load_study(path)
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 100_000  # KiB: under 100 MB more


def test_shared_values_are_counted_as_often_as_they_are_referred_to() -> None:
    shared = [1, 2, 3]
    assert expanded_size({"a": shared, "b": shared}) == 1 + 2 + 2 * 4
    # l0: 1 + 9; l1: 1 + 9 * 10; l2: 1 + 9 * 91; l3: 1 + 9 * 820; the mapping and its 4 keys: 5.
    assert expanded_size(load_yaml(alias_bomb(4), "small")) == 5 + 10 + 91 + 820 + 7381
    import yaml

    deep = yaml.safe_load(alias_bomb(7))  # 9^7 = 4.8 million values, counted without expanding them
    assert expanded_size(deep) == MAX_EXPANDED_VALUES + 1
    with pytest.raises(ValueError, match="deep expands to more than"):
        load_yaml(alias_bomb(7), "deep")
    cycle: list[object] = []
    cycle.append(cycle)
    assert expanded_size(cycle) == MAX_EXPANDED_VALUES + 1


def test_values_in_messages_are_quoted_briefly() -> None:
    assert len(brief(list(range(10**6)))) < 100
    assert len(brief("x" * 10**6)) < 100
    nested: list[object] = [0]
    for _ in range(1000):
        nested = [nested] * 3
    assert len(brief(nested)) <= 200


def test_a_resolution_written_as_5e_2_is_read_as_map_server_reads_it(tmp_path: Path) -> None:
    """YAML 1.1 (PyYAML) reads 5e-2 as text; map_server reads it as 0.05. It was refused as
    "must be a finite number"."""
    a_map_image(tmp_path)
    (tmp_path / "m.yaml").write_text("image: m.pgm\norigin: [0, 0, 0]\n" + MAP_KEYS.replace("0.05", "5e-2"))
    plan = PlanMap.from_ros_map(tmp_path / "m.yaml")
    assert plan.raster is not None and plan.raster.resolution == pytest.approx(0.05)
    (tmp_path / "bad.yaml").write_text("image: m.pgm\norigin: [0, 0, 0]\n" + MAP_KEYS.replace("0.05", "fast"))
    with pytest.raises(ValueError, match="resolution must be a finite number, got 'fast'"):
        PlanMap.from_ros_map(tmp_path / "bad.yaml")


def test_a_start_covariance_of_a_million_kilometres_keeps_the_covariance_positive_definite() -> None:
    """`initial_covariance=diag(1e12, 1e12, 10)`: the short Kalman form (I - K) P cancelled to an x/y
    variance of exactly 0 and a negative eigenvalue on the first accepted estimate."""
    from planicp import Localizer
    from planicp.plans.default_plan import load_default_plan
    from planicp.sim.experiment import ExperimentConfig, run_experiment

    plan = load_default_plan()
    recording, _ = run_experiment(plan, ExperimentConfig(duration_s=1.0, seed=1))
    localizer = Localizer(plan, tuple(recording.truth[0]), initial_covariance=np.diag([1e12, 1e12, 10.0]))
    for k in range(3):
        estimate = localizer.update(recording.scans[k], tuple(recording.odometry_in_odom[k]))
        assert estimate.accepted
        cov = estimate.covariance
        assert np.array_equal(cov, cov.T) and np.linalg.eigvalsh(cov).min() > 0.0, cov
        assert 1e-8 < cov[0, 0] < 1e-4 and 1e-8 < cov[1, 1] < 1e-4, cov  # a fit's millimetres, not 0
        assert np.hypot(*(np.array(estimate.pose[:2]) - recording.truth[k][:2])) < 0.01


def test_planicp_plan_never_writes_over_its_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`planicp plan maps/plan.yaml --out maps` overwrote the input YAML and PGM (a `mode: scale`
    map came back trinary, its comments gone)."""
    from planicp.cli import main as cli_main

    maps = tmp_path / "maps"
    maps.mkdir()
    cv2.imwrite(str(maps / "plan.pgm"), np.pad(np.zeros((20, 20), np.uint8), 10, constant_values=254))
    text = "# a scale map, commented\nimage: plan.pgm\nmode: scale\norigin: [0, 0, 0]\n" + MAP_KEYS
    (maps / "plan.yaml").write_text(text)
    pgm = (maps / "plan.pgm").read_bytes()
    assert cli_main(["plan", str(maps / "plan.yaml"), "--out", str(maps)]) == 2
    err = capsys.readouterr().err
    assert "plan.yaml is an input of this command" in err and "give another --out" in err, err
    assert (maps / "plan.yaml").read_text() == text and (maps / "plan.pgm").read_bytes() == pgm
    # The image alone as the input, written beside itself: refused too.
    assert cli_main(["plan", str(maps / "plan.pgm"), "--resolution", "0.05", "--out", str(maps)]) == 2
    assert (maps / "plan.pgm").read_bytes() == pgm
    assert cli_main(["plan", str(maps / "plan.yaml"), "--out", str(tmp_path / "elsewhere")]) == 0


def test_planicp_plan_replaces_a_symlink_in_its_output_folder_instead_of_following_it(tmp_path: Path) -> None:
    from planicp.cli import main as cli_main

    a_map_image(tmp_path)
    (tmp_path / "m.yaml").write_text("image: m.pgm\norigin: [0, 0, 0]\n" + MAP_KEYS)
    outside = tmp_path / "outside.csv"
    outside.write_text("keep me\n")
    out = tmp_path / "out"
    out.mkdir()
    (out / "wall_points.csv").symlink_to(outside)
    assert cli_main(["plan", str(tmp_path / "m.yaml"), "--out", str(out)]) == 0
    assert outside.read_text() == "keep me\n"
    assert not (out / "wall_points.csv").is_symlink() and (out / "wall_points.csv").read_text().startswith("x_m,y_m")


def _plan_image(tmp_path: Path) -> Path:
    from planicp import sim as synthetic

    path = tmp_path / "plan.png"
    cv2.imwrite(str(path), synthetic.generate_floor(3, "office", width=20.0, height=12.0, rooms=4).to_image())
    return path


@pytest.mark.parametrize("tamper", ["shifted points", "a wrong shape", "a missing array", "NaN points"])
def test_a_cache_entry_that_loads_but_was_changed_is_rebuilt(tmp_path: Path, tamper: str) -> None:
    """The cache trusted any .npz that loaded: shifted points were used silently, a wrong shape gave
    a garbage raster, a missing array raised KeyError, NaN points left the plan unloadable until
    the entry was deleted by hand."""
    path, cache = _plan_image(tmp_path), tmp_path / "cache"
    first = PlanMap.from_image(path, 0.05, cache=cache)
    (entry,) = cache.glob("*.npz")
    with np.load(entry) as data:
        arrays = {name: data[name] for name in data.files}
    name = next(n for n in arrays if n != "_checksum" and arrays[n].ndim == 2 and arrays[n].shape[1] == 2)
    if tamper == "shifted points":
        arrays[name] = arrays[name] + 1.0
    elif tamper == "a wrong shape":
        arrays[name] = arrays[name].reshape(-1)[:49].reshape(7, 7)
    elif tamper == "a missing array":
        del arrays[name]
    else:
        arrays[name] = np.full_like(arrays[name], np.nan)
    with open(entry, "wb") as f:
        np.savez(f, **arrays)
    again = PlanMap.from_image(path, 0.05, cache=cache)
    assert not again.from_cache
    np.testing.assert_array_equal(again.points, first.points)
    assert PlanMap.from_image(path, 0.05, cache=cache).from_cache  # the rebuilt entry is trusted


def test_a_read_only_cache_folder_is_skipped_with_a_warning(tmp_path: Path) -> None:
    """A robot with a read-only home could not load its plan ("[Errno 30] Read-only file system")."""
    import os

    path, cache = _plan_image(tmp_path), tmp_path / "cache"
    cache.mkdir()
    cache.chmod(0o500)
    try:
        if os.access(cache, os.W_OK):
            pytest.skip("running as a user whom file modes do not stop (root)")
        with pytest.warns(UserWarning, match=r"plan cache .*cache cannot be written .*prepared without it"):
            plan = PlanMap.from_image(path, 0.05, cache=cache)
        assert len(plan) > 0 and not plan.from_cache
    finally:
        cache.chmod(0o700)


def test_a_cache_folder_that_cannot_be_made_is_skipped_with_a_warning(tmp_path: Path) -> None:
    path = _plan_image(tmp_path)
    with pytest.warns(UserWarning, match=r"plan cache .* cannot be written .*prepared without it"):
        plan = PlanMap.from_image(path, 0.05, cache=path / "cache")  # a file where a folder should be
    assert len(plan) > 0 and not plan.from_cache


@pytest.mark.parametrize("suffix", [".png", ".jpg", ".bmp", ".pgm", ".ppm", ".tif"])
def test_image_dimensions_come_from_the_header(tmp_path: Path, suffix: str) -> None:
    from planicp.plans.image_files import image_dimensions

    path = tmp_path / f"a{suffix}"
    channels = (37, 53, 3) if suffix == ".ppm" else (37, 53)
    assert cv2.imwrite(str(path), np.full(channels, 128, np.uint8))
    assert image_dimensions(path) == (53, 37)


def test_an_image_of_a_billion_pixels_is_refused_from_its_header(tmp_path: Path) -> None:
    """A 0.95 MB PNG of 30000 x 30000 pixels peaked at 5.2 GB; 50000^2 gave a raw cv2.error. The
    size is read from the header and refused before any pixel is decoded (here the header is all
    there is: decoding would fail)."""
    import struct
    import zlib

    ihdr = struct.pack(">IIBBBBB", 30000, 30000, 8, 0, 0, 0, 0)
    chunk = b"IHDR" + ihdr
    png = b"\x89PNG\r\n\x1a\n" + struct.pack(">I", len(ihdr)) + chunk + struct.pack(">I", zlib.crc32(chunk))
    (tmp_path / "huge.png").write_bytes(png + b"\x00" * 100)
    (tmp_path / "huge.pgm").write_bytes(b"P5\n# a comment\n50000 50000\n255\n" + b"\x00" * 100)
    for name in ("huge.png", "huge.pgm"):
        with pytest.raises(
            ValueError, match=r"is \d+ x \d+ pixels \(\d+ million\); plan images are read up to 200 mil"
        ):
            PlanMap.from_image(tmp_path / name, 0.05, cache=False)
    (tmp_path / "m.yaml").write_text("image: huge.png\norigin: [0, 0, 0]\n" + MAP_KEYS)
    with pytest.raises(ValueError, match=r"ROS map image .* is 30000 x 30000 pixels"):
        PlanMap.from_ros_map(tmp_path / "m.yaml", cache=False)


def test_a_sparse_file_claiming_gigabytes_is_refused_before_it_is_read(tmp_path: Path) -> None:
    path = tmp_path / "sparse.png"
    with open(path, "wb") as f:
        f.truncate(2 << 30)  # 2 GiB, no blocks on disk
    with pytest.raises(ValueError, match=r"is 2048 MiB; plan images are read up to 1024 MiB"):
        PlanMap.from_image(path, 0.05)


def test_colour_images_convert_to_grey_as_the_mean_of_their_channels(tmp_path: Path) -> None:
    from planicp.plans.plan_raster import load_gray

    rng = np.random.default_rng(1)
    rgba = rng.integers(0, 256, (300, 200, 4), dtype=np.uint8)
    expected = rgba[:, :, :3].astype(np.float64).mean(axis=2)
    a = rgba[:, :, 3] / 255.0
    expected = (expected * a + 255.0 * (1.0 - a)).astype(np.uint8)
    np.testing.assert_array_equal(load_gray(rgba), expected)
    rgb16 = rng.integers(0, 65536, (50, 40, 3), dtype=np.uint16)
    np.testing.assert_array_equal(
        load_gray(rgb16), load_gray(rgb16[:, :, :3].astype(np.float64).mean(axis=2).astype(np.uint16))
    )


def test_a_log_line_of_megabytes_is_cut_skipped_and_never_held_whole(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A 1.5 MB .log.gz with one 1.6 GB line reached 4.75 GB, and the line's token was embedded in
    the error. Here with the limit lowered to 1 kB: the long line is cut, skipped as malformed and
    quoted by a short prefix; the lines around it are read."""
    import gzip

    from planicp.io import carmen, text_source

    monkeypatch.setattr(text_source, "MAX_LINE_BYTES", 1000)
    good = "FLASER 3 1.0 1.1 1.2 0.0 0.0 0.0 0.0 0.0 0.0 {t} host {t}\n"
    text = good.format(t=1.0) + "FLASER 3 " + "9" * 200_000 + " 1.0\n" + good.format(t=2.0) + good.format(t=3.0)
    path = tmp_path / "long.log.gz"
    with gzip.open(path, "wt") as f:
        f.write(text)
    with pytest.warns(UserWarning) as caught:
        log = carmen.read_carmen(path)
    assert len(log) == 3 and sum(log.skipped.values()) == 1, log.skipped
    message = " ".join(str(w.message) for w in caught)
    assert "skipped 1 malformed line(s); first at line 2" in message and "9" * 100 not in message, message
    lines = list(text_source.read_lines(path))
    assert lines[1] == (2, "FLASER 3 " + "9" * 51 + " ... (a line of 200014 bytes, longer than 1000: cut)")
    assert [n for n, _ in lines] == [1, 2, 3, 4]


def test_a_scan_of_identical_points_is_refused_the_same_way_on_every_update() -> None:
    """1000 identical points were accepted on a first update (moving the pose 1.8 cm), and later
    raised from a search ("1 usable points") and flipped `lost`. Now such a scan is never aligned:
    the prediction stands, on every update, and no stage raises."""
    from planicp import Localizer
    from planicp.plans.default_plan import load_default_plan
    from planicp.sim.experiment import ExperimentConfig, run_experiment

    plan = load_default_plan()
    rec, _ = run_experiment(plan, ExperimentConfig(duration_s=3.0, seed=1))
    loc = Localizer(plan, tuple(rec.truth[0]))
    same = np.tile(rec.scans[0][100], (1000, 1))  # a return on a wall, a thousand times
    first = loc.update(same, tuple(rec.odometry_in_odom[0]))
    assert not first.accepted and first.result is None and first.pose == first.predicted_pose
    assert first.reason == "scan covers 1 cells of 0.2 m (need 10): too little of the scene to place the robot"
    for k in range(1, 5):
        assert loc.update(rec.scans[k], tuple(rec.odometry_in_odom[k])).accepted
    for k in range(5, 12):  # long enough to be declared lost: the recovery coasts, nothing raises
        estimate = loc.update(same, tuple(rec.odometry_in_odom[k]))
        assert not estimate.accepted and estimate.result is None
    assert estimate.lost
    back = [loc.update(rec.scans[k], tuple(rec.odometry_in_odom[k])) for k in range(12, 30)]
    assert not back[-1].lost and np.hypot(*(np.array(back[-1].pose[:2]) - rec.truth[29][:2])) < 0.05


def test_an_occupancy_grid_too_fine_for_its_cell_budget_is_refused_before_anything_large_is_made() -> None:
    """EnhancedOccupancyGrid(office, resolution=0.001) took 3 GB and 20 s before its error (the
    walls' samples, 2500 per wall pixel), and 0.0005 raised MemoryError."""
    from planicp import EnhancedOccupancyGrid
    from planicp.plans.default_plan import load_default_plan

    plan = load_default_plan()
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    for resolution in (0.001, 0.0005):
        with pytest.raises(
            ValueError, match=r"would need about [\d.e+]+ cells \(max_cells 16777216\); give a resolution of at least"
        ):
            EnhancedOccupancyGrid(plan, resolution=resolution)
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 50_000  # KiB


def test_dxf_arcs_of_cad_float_noise_and_of_absurd_radius_give_a_plan_or_one_clear_error(tmp_path: Path) -> None:
    """A bulge of 1e-15 (ordinary CAD float noise) and a CIRCLE of radius 1e17 gave
    ZeroDivisionError from the CLI; a CIRCLE of radius 1e14 took 4.9 GB."""
    ezdxf = pytest.importorskip("ezdxf")
    from planicp.plans.vector_plan import dxf_segments

    doc = ezdxf.new()
    msp = doc.modelspace()
    msp.add_lwpolyline([(0.0, 0.0, 0.0, 0.0, 1e-15), (5.0, 0.0), (5.0, 4.0), (0.0, 4.0)], close=True)
    doc.saveas(tmp_path / "noise.dxf")
    segments = dxf_segments(tmp_path / "noise.dxf")
    assert len(segments) == 4  # the nearly straight bulge is its chord
    for radius in (1e14, 1e17):
        doc = ezdxf.new()
        doc.modelspace().add_line((0.0, 0.0), (5.0, 0.0))
        doc.modelspace().add_circle((0.0, 0.0), radius)
        doc.saveas(tmp_path / "huge.dxf")
        before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        with pytest.raises(
            ValueError,
            match=r"huge\.dxf': CIRCLE .* on layer 0: an arc of radius 1e\+1[47] drawing "
            r"units would take \d+ points .* check the drawing's units",
        ):
            dxf_segments(tmp_path / "huge.dxf")
        assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 50_000


@pytest.mark.parametrize("kind", ["LWPOLYLINE", "CIRCLE", "ARC"])
@pytest.mark.parametrize("value", [float("nan"), float("inf")])
def test_dxf_arcs_of_non_finite_bulge_centre_or_radius_are_one_clear_error(
    tmp_path: Path, kind: str, value: float
) -> None:
    """ezdxf writes and reads back 'nan' and 'inf'. Its virtual_entities() silently drops a bulge
    of NaN radius, so the reader checks each arc itself; an infinite bulge was refused as an arc
    of radius 4e15 (tan(pi) rounded) needing 1.4e9 points."""
    ezdxf = pytest.importorskip("ezdxf")
    from planicp.plans.vector_plan import dxf_segments

    doc = ezdxf.new()
    msp = doc.modelspace()
    msp.add_line((0.0, 0.0), (5.0, 0.0))
    if kind == "LWPOLYLINE":
        msp.add_lwpolyline([(0.0, 0.0, 0.0, 0.0, value), (1.0, 0.0)])  # a bulge of NaN or inf
    elif kind == "CIRCLE":
        msp.add_circle((value, 0.0), 1.0)
    else:
        msp.add_arc((0.0, 0.0), value, 0.0, 90.0)
    doc.saveas(tmp_path / "odd.dxf")
    with pytest.raises(
        ValueError, match=rf"odd\.dxf': {kind} \w+ on layer 0: an arc with no finite radius \(its centre"
    ):
        dxf_segments(tmp_path / "odd.dxf")


def test_house_expo_files_that_nest_too_deep_hold_huge_numbers_or_ask_for_a_huge_raster(tmp_path: Path) -> None:
    """A HouseExpo JSON nested 3000 deep gave RecursionError, a 400-digit number OverflowError, and
    rasterising at 0.0005 m took 5.3 GB."""
    house = {"verts": [[0, 0], [10, 0], [10, 8], [0, 8]], "bbox": {"min": [0, 0], "max": [10, 8]}}
    (tmp_path / "deep.json").write_text("[" * 3000 + "]" * 3000)
    with pytest.raises(ValueError, match="nests its values too deeply"):
        PlanMap.from_house_expo(tmp_path / "deep.json")
    big = {**house, "verts": [[0, 0], [10**400, 0], [10, 8]]}
    with pytest.raises(ValueError, match="key 'verts' holds a number too large for a coordinate"):
        PlanMap.from_house_expo(big)
    with pytest.raises(ValueError, match=r"a raster of 2\.06e\+04 x 1\.66e\+04 pixels at 0\.0005 m is too large"):
        PlanMap.from_house_expo(house, resolution=0.0005)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    fine = PlanMap.from_house_expo(house, resolution=0.002)  # 25 million pixels, a block of rows at a time
    assert fine.raster is not None and resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 400_000


def test_a_folder_a_device_or_a_symlink_loop_as_the_image_is_named_as_what_it_is(tmp_path: Path) -> None:
    """/dev/zero or a folder given as the image was reported as "does not exist", and an image
    symlink loop raised RuntimeError."""
    import os

    with pytest.raises(ValueError, match=r"plan image .* is a folder: give the image file itself"):
        PlanMap.from_image(tmp_path, 0.05)
    if os.path.exists("/dev/zero"):
        with pytest.raises(ValueError, match=r"plan image /dev/zero is not a regular file \(a device or a pipe\)"):
            PlanMap.from_image("/dev/zero", 0.05)
    loop = tmp_path / "loop.png"
    loop.symlink_to(tmp_path / "loop.png")
    with pytest.raises(ValueError, match=r"plan image .*loop\.png cannot be opened: Too many levels of symbolic links"):
        PlanMap.from_image(loop, 0.05)
    (tmp_path / "m.yaml").write_text("image: loop.png\norigin: [0, 0, 0]\n" + MAP_KEYS)
    with pytest.raises(ValueError, match=r"ROS map image \(from .*m\.yaml\) .*loop\.png cannot be opened"):
        PlanMap.from_ros_map(tmp_path / "m.yaml", cache=False)
    with pytest.raises(FileNotFoundError, match="does not exist"):
        PlanMap.from_image(tmp_path / "missing.png", 0.05)


@pytest.mark.parametrize(
    ("line", "match"),
    [
        ("image: [m.pgm]", r"image must be the image file's name, got \['m\.pgm'\]"),
        ("image: m.pgm\nmode: [trinary]", r"mode must be one of .*, got \['trinary'\]"),
        ("image: m.pgm\norigin: [0, [1], 0]", r"origin must be three numbers, got \[0, \[1\], 0\]"),
        ("image: m.pgm\nnegate: [0]", r"negate must be 0 or 1, got \[0\]"),
    ],
)
def test_a_ros_map_value_of_the_wrong_type_is_named_briefly(tmp_path: Path, line: str, match: str) -> None:
    a_map_image(tmp_path)
    keys = {"origin": "[0, 0, 0]", "negate": "0"}
    text = line + "\n" + "".join(f"{k}: {v}\n" for k, v in keys.items() if f"{k}:" not in line)
    (tmp_path / "m.yaml").write_text(text + MAP_KEYS.replace("negate: 0\n", ""))
    with pytest.raises(ValueError, match=match):
        PlanMap.from_ros_map(tmp_path / "m.yaml", cache=False)


def test_yaml_documents_too_long_too_deep_or_invalid_are_refused_naming_the_source(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from planicp.io import yaml_documents

    with pytest.raises(ValueError, match="^doc.yaml nests its values too deeply"):
        load_yaml("[" * 5000 + "]" * 5000, "doc.yaml")
    with pytest.raises(ValueError, match="^doc.yaml is not valid YAML"):
        load_yaml("a: [1, 2", "doc.yaml")
    monkeypatch.setattr(yaml_documents, "MAX_DOCUMENT_BYTES", 10)
    with pytest.raises(ValueError, match="^doc.yaml is 16 characters long; a YAML document here is at most 10"):
        load_yaml("a: 1\nb: 2\nc: 3\nd", "doc.yaml")


@pytest.mark.parametrize("option", ["--open-px", "--close-px"])
@pytest.mark.parametrize("size", [10**9, 2**40])
def test_a_morphology_size_larger_than_the_image_is_one_clear_line(
    tmp_path: Path, option: str, size: int, capsys: pytest.CaptureFixture[str]
) -> None:
    """`--open-px 1e9` gave a raw cv2.error (a 10^18-byte kernel), `--close-px 2**40` "Can't parse 'ksize'"."""
    image = tmp_path / "plan.png"
    cv2.imwrite(str(image), np.pad(np.zeros((20, 20), np.uint8), 10, constant_values=255))
    code = cli_main(
        ["plan", str(image), "--resolution", "0.05", option, str(size), "--out", str(tmp_path / "out"), "--no-cache"]
    )
    err = capsys.readouterr().err
    assert code == 2 and len(err.splitlines()) == 1
    assert f"{option[2:].replace('-', '_')}={size} pixels is larger than the plan image" in err and "40 x 40" in err


def test_a_binary_file_given_as_a_log_gives_a_short_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """5 MB of random bytes to `replay` gave a 1.26 MB error quoting every junk "record type"."""
    log = tmp_path / "binary.log"
    log.write_bytes(np.random.default_rng(0).integers(0, 256, 5_000_000, dtype=np.uint8).tobytes())
    code = cli_main(["replay", str(log), "--plan", str(default_plan_path()), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and len(err) < 400, err[:1000]
    assert "no usable FLASER, RLASER or ROBOTLASER1 line" in err and "(not a record): " in err


@pytest.mark.parametrize(
    ("param", "reason"),
    [
        ("robot_front_laser_max abc", "is not a number"),
        ("robot_front_laser_max -5", "must be a positive number of metres"),
        ("robot_front_laser_max 1e400", "must be a positive number of metres"),
        ("robot_frontlaser_offset 1e300", "must be a finite number within"),
    ],
)
def test_a_bad_param_line_is_skipped_and_named_not_the_whole_log(tmp_path: Path, param: str, reason: str) -> None:
    """`PARAM robot_front_laser_max -5` refused the whole log ("need 0 <= range_min < range_max")
    without naming file or line; `abc` or `1e300` were silently ignored or used."""
    lines = ["PARAM " + param + " nohost 0", *carmen_excerpt.log_lines()]
    path = tmp_path / "param.log"
    path.write_text("\n".join(lines) + "\n")
    with pytest.warns(
        UserWarning,
        match=rf"param.log: skipped 1 malformed line\(s\); first at line 1 \(PARAM\): "
        rf"{param.split()[0]}.*{reason}.*the default is used",
    ):
        log = read_carmen(path)
    clean = tmp_path / "clean.log"
    clean.write_text("\n".join(carmen_excerpt.log_lines()) + "\n")
    reference = read_carmen(clean)
    assert len(log) == carmen_excerpt.SCANS and log.skipped["PARAM (malformed)"] == 1
    assert log[3].laser_pose == reference[3].laser_pose
    np.testing.assert_array_equal(log[3].ranges, reference[3].ranges)
    with pytest.raises(ValueError, match=rf"param.log, line 1: bad PARAM line: {param.split()[0]}"):
        read_carmen(path, errors="raise")


def test_plans_from_scans_too_fine_for_the_pixel_budget_name_the_finest_resolution_that_fits(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`evaluate-log --resolution 1e-6` tried to allocate 313 TiB (a traceback)."""
    path = tmp_path / "room.log"
    path.write_text("\n".join(carmen_excerpt.log_lines()) + "\n")
    code = cli_main(["evaluate-log", str(path), "--resolution", "1e-6", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1
    finest = float(re.search(r"give a resolution of at least ([0-9.e-]+) m", err).group(1))  # type: ignore[union-attr]
    # The quoted resolution fits the budget, and it is the finest that does (within 20 %).
    log = read_carmen(path)
    even = [f for k, f in enumerate(log) if k % 2 == 0]
    plan_from_scans(even, finest)
    with pytest.raises(ValueError, match="give a resolution of at least"):
        plan_from_scans(even, finest / 1.2)


def test_an_occupancy_grid_too_fine_names_the_finest_resolution_that_fits() -> None:
    plan = load_default_plan()
    with pytest.raises(PlanicpError, match="give a resolution of at least") as error:
        EnhancedOccupancyGrid(plan, resolution=0.0005)
    finest = float(re.search(r"at least ([0-9.e-]+) m", str(error.value)).group(1))  # type: ignore[union-attr]
    EnhancedOccupancyGrid(plan, resolution=finest)
    with pytest.raises(PlanicpError):
        EnhancedOccupancyGrid(plan, resolution=finest * 0.98)


# Found by fuzzing the readers (tests/reader_fuzzing.py, benches/fuzz_readers.py): each failed as
# the test's docstring says before its fix.


def _peak_growth_kib(before: int) -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before


def test_a_yaml_file_over_the_document_limit_is_refused_before_it_is_read(tmp_path: Path) -> None:
    """A 1.2 MB study (a list of 400,000 zeros) took 83 s in PyYAML's pure-Python parser before it
    was refused, and a file was read whole before its length was checked. Now PyYAML's C parser is
    used when it is there, and a YAML file over 256 KiB is refused from its size alone."""
    from planicp.io.yaml_documents import MAX_DOCUMENT_BYTES

    (tmp_path / "s.yaml").write_text("name: x\nplans: [default]\nfurniture: [" + ", ".join(["0"] * 400_000) + "]\n")
    with pytest.raises(StudyError, match=r"s\.yaml is 1200037 bytes long; a YAML document here is at most 262144"):
        load_study(tmp_path / "s.yaml")
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    for name in ("sparse.yaml", "m.yaml"):
        with open(tmp_path / name, "wb") as f:
            f.truncate(2 << 30)  # 2 GiB, no blocks on disk
    with pytest.raises(StudyError, match=r"sparse\.yaml is 2147483648 bytes long"):
        load_study(tmp_path / "sparse.yaml")
    with pytest.raises(ValueError, match=r"ROS map .*m\.yaml is 2147483648 bytes long"):
        PlanMap.from_ros_map(tmp_path / "m.yaml", cache=False)
    assert _peak_growth_kib(before) < 50_000
    # A document just under the limit is read (in seconds even without the C parser).
    text = "name: x\nplans: [default]\nfurniture: [0, 0.5, 2]\n# " + "x" * 200_000 + "\n"
    assert len(text) < MAX_DOCUMENT_BYTES
    (tmp_path / "ok.yaml").write_text(text)
    assert load_study(tmp_path / "ok.yaml")[0].furniture == (0.0, 0.5, 2.0)


def test_a_study_value_made_of_a_long_string_aliased_thousands_of_times_is_quoted_briefly(tmp_path: Path) -> None:
    """`plans: [[&s "x" * 100000, *s, *s, ...]]`: 30,000 aliases, well under the limit of values, but
    the message quoted the list with repr(): 3 GB of text, a MemoryError after 26 s and 2.4 GB."""
    text = 'name: x\nplans: [[&s "' + "x" * 100_000 + '", ' + ", ".join(["*s"] * 30_000) + "]]\n"
    (tmp_path / "s.yaml").write_text(text)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(
        StudyError, match=r"key 'plans\[0\]' must be a path or a mapping with 'path', got \['xxx"
    ) as info:
        load_study(tmp_path / "s.yaml")
    assert len(str(info.value)) < 400 and _peak_growth_kib(before) < 100_000


def test_a_study_asking_for_a_trillion_seeds_is_refused(tmp_path: Path) -> None:
    """`seeds: {count: 1000000000000}` raised MemoryError building the tuple of seeds."""
    (tmp_path / "s.yaml").write_text("name: x\nplans: [default]\nseeds: {start: 5, count: 1000000000000}\n")
    with pytest.raises(
        StudyError, match=r"key 'seeds.count' asks for 1000000000000 seeds; a study runs at most 100000"
    ):
        load_study(tmp_path / "s.yaml")
    (tmp_path / "s.yaml").write_text("name: x\nplans: [default]\nseeds: {start: 5, count: 3}\n")
    assert load_study(tmp_path / "s.yaml")[0].seeds == (5, 6, 7)


FLASER = "FLASER 3 1.0 1.1 1.2 {pose} 0.0 0.0 0.0 {t} host {t}\n"


def _zip_log(text: str) -> bytearray:
    import io
    import zipfile

    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        archive.writestr("log.txt", text)
    return bytearray(buffer.getvalue())


@pytest.mark.parametrize("damage", ["local header", "offset before the start", "checksum", "version"])
def test_a_damaged_zip_log_is_a_value_error_naming_the_file(tmp_path: Path, damage: str) -> None:
    """A zip log whose member header was damaged raised zipfile.BadZipFile, one whose directory put
    the member before the file's start OSError [Errno 22], a bad CRC-32 BadZipFile and a member
    needing zip version 8.4 NotImplementedError (g2o and CARMEN alike)."""
    from planicp.io import read_carmen, read_g2o

    data = _zip_log(FLASER.format(pose="0.0 0.0 0.0", t=1.0) + FLASER.format(pose="0.0 0.0 0.0", t=2.0))
    end = data.rfind(b"PK\x05\x06")
    central = data.rfind(b"PK\x01\x02")
    if damage == "local header":
        data[0:4] = b"PK\x03\x04"
        offset = int.from_bytes(data[central + 42 : central + 46], "little")
        data[central + 42 : central + 46] = (offset + 5).to_bytes(4, "little")
    elif damage == "offset before the start":
        offset = int.from_bytes(data[end + 16 : end + 20], "little")
        data[end + 16 : end + 20] = (offset + 10).to_bytes(4, "little")
    elif damage == "version":
        data[central + 6] = 84  # the version needed to extract: 8.4
    else:
        data[14] ^= 0xFF  # the CRC-32 in the local header
        data[central + 16] ^= 0xFF  # and in the central directory
    path = tmp_path / "r.log"
    path.write_bytes(bytes(data))
    if damage == "checksum":  # found on the member's first block: no line before the break
        with pytest.raises(ValueError, match=r"r\.log: no usable .* \(skipped: \(compressed stream ends early\): 1"):
            read_carmen(path)
        with pytest.raises(
            ValueError,
            match=r"r\.log: compressed data ends early or is corrupt after line 0: Bad CRC-32 "
            r"for file 'log\.txt'",
        ):
            read_carmen(path, errors="raise")
        return
    match = (
        r"starts like a zip archive but is not one \(zip file version 8\.4\)"
        if damage == "version"
        else r"the file 'log\.txt' in this zip archive cannot be read"
    )
    for reader in (read_carmen, read_g2o):
        with pytest.raises(ValueError, match=r"r\.log: " + match):
            reader(path)


@pytest.mark.parametrize("packing", ["gz", "zip"])
def test_a_compressed_log_that_expands_hundreds_of_times_is_refused(
    tmp_path: Path, packing: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A 1.5 MB gzip log expanding to 1.2 GB of text took 15 s only to decompress (and its lines, had
    they been scans, gigabytes). Real logs expand 3 to 5 times; over 100 times, and past 16 MiB (1
    MiB here, to keep the test fast), is refused whatever errors= says."""
    import gzip
    import io
    import zipfile

    from planicp.io import read_carmen, text_source

    monkeypatch.setattr(text_source, "EXPANSION_FLOOR", 1 << 20)
    text = (FLASER.format(pose="0 0 0", t=1.0) + "# padding\n" * 300_000).encode()
    path = tmp_path / f"bomb.log.{packing}"
    if packing == "gz":
        path.write_bytes(gzip.compress(text))
    else:
        buffer = io.BytesIO()
        with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
            archive.writestr("bomb.log", text)
        path.write_bytes(buffer.getvalue())
    assert len(text) > 100 * path.stat().st_size
    for errors in ("skip", "raise"):
        with pytest.raises(
            ValueError,
            match=r"bomb\.log\.(gz|zip): the compressed log expands to more than \d+ bytes, "
            r"over 100 times its size .* refused as a decompression bomb",
        ):
            read_carmen(path, errors=errors)  # type: ignore[arg-type]
    path.write_bytes(gzip.compress(text[:900_000]))  # under the floor: read
    assert len(read_carmen(path)) == 1


def test_a_carmen_maximum_range_param_of_zero_or_less_is_ignored(tmp_path: Path) -> None:
    """`PARAM robot_front_laser_max 0` raised "need 0 <= range_min < range_max, got 0.0, 0.0" (naming
    no file) for the whole log."""
    from planicp.io import read_carmen

    for value in ("0", "-5"):
        path = tmp_path / "r.log"
        path.write_text(
            f"PARAM robot_front_laser_max {value}\n"
            + FLASER.format(pose="0 0 0", t=1.0)
            + FLASER.format(pose="0 0 0", t=2.0)
        )
        log = read_carmen(path)
        assert len(log) == 2 and log[0].range_max == 80.0


def test_a_log_line_with_a_pose_beyond_the_coordinate_limit_is_skipped_as_malformed(tmp_path: Path) -> None:
    """A FLASER pose of 1e308 m raised "reference has a coordinate of 1.000000e+308 m" (naming no
    file) for the whole log; now that line is malformed, the others are read."""
    from planicp.io import read_carmen, read_g2o, read_g2o_graph

    path = tmp_path / "r.log"
    path.write_text(
        FLASER.format(pose="0 0 0", t=1.0)
        + FLASER.format(pose="1e308 0 0", t=1.5)
        + "ODOM 1e12 0 0 0 0 0 1.7 host 1.7\n"
        + FLASER.format(pose="0 0 0", t=2.0)
    )
    with pytest.warns(
        UserWarning,
        match=r"r\.log: skipped 2 malformed line\(s\); first at line 2 \(FLASER\): the laser "
        r"and odometry poses: a coordinate of 1e\+308 m is beyond \+-1e\+09 m",
    ):
        log = read_carmen(path)
    assert len(log) == 2 and log.skipped == {"FLASER (malformed)": 1, "ODOM (malformed)": 1}
    with pytest.raises(
        ValueError, match=r"r\.log, line 2: bad FLASER line: the laser and odometry poses: a coordinate"
    ):
        read_carmen(path, errors="raise")
    # A mount (the laser's pose in the robot, from a ROBOTLASER1 line's two poses) beyond the limit:
    # the line is malformed, not the log.
    scan = "ROBOTLASER1 0 -1.57 3.14 0.785 50.0 0.1 0 5 1.0 1.1 1.2 1.1 1.0 0 {poses} 0 0 0.5 0.5 0.5 {t} nohost {t}\n"
    path.write_text(scan.format(poses="9e8 0 0 -9e8 0 0", t=1.0) + scan.format(poses="0.2 0 0 0 0 0", t=2.0))
    with pytest.warns(UserWarning, match=r"first at line 1 \(ROBOTLASER1\): laser_pose has a coordinate of 1\.8"):
        assert len(read_carmen(path, reference=False)) == 1
    graph = tmp_path / "g.g2o"
    scan = scan.replace("{poses}", "0.2 0.0 0.0 0.0 0.0 0.0")
    graph.write_text(
        "VERTEX_SE2 0 0 0 0\n"
        + scan.format(t=1.0)
        + "VERTEX_SE2 1 1e300 0 0\n"
        + scan.format(t=2.0)
        + "VERTEX_SE2 2 1 0 0\n"
        + scan.format(t=3.0)
    )
    with pytest.warns(UserWarning, match=r"skipped 2 malformed line\(s\); first at line 3 \(VERTEX_SE2\)"):
        log = read_g2o(graph)
    assert [f.odometry for f in log] == [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0)]  # the scan of vertex 1 is not vertex 0's
    with pytest.warns(UserWarning):
        assert read_g2o_graph(graph).vertex_ids.tolist() == [0, 2]


def test_a_record_kind_of_hundreds_of_kilobytes_is_quoted_briefly(tmp_path: Path) -> None:
    """A line whose first token was 300,000 digits gave a 300 KB message (the token, as a record
    kind in `skipped`, quoted whole)."""
    from planicp.io import read_carmen, read_g2o

    path = tmp_path / "r.log"
    path.write_text("9" * 300_000 + " 1 2\n")
    for reader in (read_carmen, read_g2o):
        with pytest.raises(ValueError, match=r"r\.log: no .* \(skipped: \(not a record\): 1\)") as info:
            reader(path)
        assert len(str(info.value)) < 300


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("0\nSECTION\n0\nENDSEC\n0\nEOF\n", r" could not be read as DXF: IndexError: list index out of range"),
        (
            "0\nSECTION\n2\nENTITIES\n0\nPOLYLINE\n8\n0\n66\n1\n70\n0\n0\nVERTEX\n8\n0\n42\n0.0\n0\nVERTEX\n8\n0\n10\n1.0\n"
            "20\n0.0\n0\nSEQEND\n0\nENDSEC\n0\nEOF\n",
            r": POLYLINE \w+ on layer 0: damaged \(AttributeError: 'NoneType' object has no attribute 'x'\)",
        ),
    ],
)
def test_a_damaged_dxf_file_is_a_value_error_naming_the_file(tmp_path: Path, text: str, match: str) -> None:
    """ezdxf's recovery raised IndexError on a SECTION without a name, and a recovered VERTEX
    without a location gave AttributeError from the reader."""
    pytest.importorskip("ezdxf")
    (tmp_path / "d.dxf").write_text(text)
    with pytest.raises(ValueError, match=r"DXF file '.*d\.dxf'" + match):
        PlanMap.from_dxf(tmp_path / "d.dxf")


def test_vector_plans_too_large_for_their_spacing_are_refused_before_sampling_naming_the_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A 4 KB HouseExpo file with one vertex 260 km away had 26 million points sampled (61 s, 2.6
    GB) before the core refused their visibility raster, in a message naming no file; a DXF or
    HouseExpo plan of too many points was refused naming no file either."""
    import json

    house = {"verts": [[0, 0], [10, 0], [10, 260_000], [0, 8]], "bbox": {"min": [0, 0], "max": [10, 260_000]}}
    (tmp_path / "h.json").write_text(json.dumps(house))
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(
        ValueError,
        match=r"HouseExpo file '.*h\.json': walls spanning 10 x 260000 m need a visibility "
        r"raster of 2\.91e\+09 cells at 0\.03 m \(limit 268435456\)",
    ):
        PlanMap.from_house_expo(tmp_path / "h.json")
    assert _peak_growth_kib(before) < 50_000
    from planicp.plans import vector_plan

    monkeypatch.setattr(vector_plan, "_MAX_SAMPLES", 1000)
    (tmp_path / "h.json").write_text(
        json.dumps({"verts": [[0, 0], [30, 0], [30, 20]], "bbox": {"min": [0, 0], "max": [30, 20]}})
    )
    with pytest.raises(ValueError, match=r"HouseExpo file '.*h\.json': sampling .* more than 1000 points"):
        PlanMap.from_house_expo(tmp_path / "h.json")
    ezdxf = pytest.importorskip("ezdxf")
    doc = ezdxf.new()
    doc.modelspace().add_line((0.0, 0.0), (100.0, 0.0))
    doc.saveas(tmp_path / "d.dxf")
    with pytest.raises(
        ValueError, match=r"DXF file '.*d\.dxf': sampling 100 m of walls every 0\.02 m gives more than 1000"
    ):
        PlanMap.from_dxf(tmp_path / "d.dxf")


@pytest.mark.parametrize(
    ("values", "match"),
    [
        ("resolution: 0.05\norigin: [1e12, 0, 0]", r"origin \['1e12', 0, 0\] is beyond \+-1e\+09 m"),
        (
            "resolution: 1.0e9\norigin: [0, 0, 0]",
            r"its 20 x 20 pixels at 1e\+09 m from origin \[0, 0, 0\] reach beyond",
        ),
    ],
)
def test_a_ros_map_beyond_the_coordinate_limit_is_refused_naming_the_map(
    tmp_path: Path, values: str, match: str
) -> None:
    """An origin of 1e12 m gave "origin has a coordinate of 1.000000e+12 m" and a resolution of 1e9 m
    the core's "plan has a coordinate of 1.45e10 m", neither naming the map."""
    a_map_image(tmp_path)
    (tmp_path / "m.yaml").write_text(f"image: m.pgm\n{values}\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    with pytest.raises(ValueError, match=r"ROS map .*m\.yaml: " + match):
        PlanMap.from_ros_map(tmp_path / "m.yaml", cache=False)


@pytest.mark.parametrize("damage", ["an unterminated header", "a shape of 10^11"])
def test_a_cache_entry_with_a_damaged_array_header_is_rebuilt(tmp_path: Path, damage: str) -> None:
    """An entry whose .npy header was cut raised tokenize.TokenError from np.load, and one claiming
    a shape of 10^11 made numpy allocate 745 GiB (MemoryError) before reading it."""
    import re
    import zipfile

    path, cache = _plan_image(tmp_path), tmp_path / "cache"
    first = PlanMap.from_image(path, 0.05, cache=cache)
    (entry,) = cache.glob("*.npz")
    with zipfile.ZipFile(entry) as archive:
        members = [(info.filename, archive.read(info)) for info in archive.infolist()]
    name, body = members[0]
    if damage == "an unterminated header":
        body = body.replace(b"'descr':", b"'descr': (", 1)
    else:
        body = re.sub(rb"'shape': \([^)]*\)", b"'shape': (100000000000,)", body, count=1)
    members[0] = (name, body)
    with zipfile.ZipFile(entry, "w") as archive:
        for member, data in members:
            archive.writestr(member, data)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    again = PlanMap.from_image(path, 0.05, cache=cache)
    assert not again.from_cache and _peak_growth_kib(before) < 100_000
    np.testing.assert_array_equal(again.points, first.points)


def test_a_pgm_header_claiming_a_width_of_hundreds_of_digits_is_refused_briefly(tmp_path: Path) -> None:
    """A PGM header giving a width of 400 digits raised OverflowError ("int too large to convert to
    float") from the message that refused it."""
    (tmp_path / "p.pgm").write_bytes(b"P5\n" + b"9" * 400 + b" 10\n255\n" + b"\x00" * 100)
    with pytest.raises(
        ValueError, match=r"p\.pgm is 999\.\.\.\(400 digits\) x 10 pixels \(999\.\.\.\(395 digits\) million\)"
    ):
        PlanMap.from_image(tmp_path / "p.pgm", 0.05, cache=False)


@pytest.mark.parametrize(
    ("image", "match"),
    [
        ('"m\\0.pgm"', r"image 'm\\x00\.pgm' is no file name: it holds a NUL character"),
        ("m" * 300 + ".pgm", r"image 'mmm.*' cannot be opened: File name too long"),
    ],
)
def test_a_ros_map_image_name_the_file_system_cannot_take_is_refused_naming_the_map(
    tmp_path: Path, image: str, match: str
) -> None:
    """An image name holding a NUL raised ValueError "embedded null byte" (naming no map), and one of
    300 characters OSError [Errno 36] File name too long."""
    (tmp_path / "m.yaml").write_text(f"image: {image}\norigin: [0, 0, 0]\n" + MAP_KEYS)
    with pytest.raises(ValueError, match=r"ROS map .*m\.yaml: " + match):
        PlanMap.from_ros_map(tmp_path / "m.yaml", cache=False)


def test_a_house_expo_file_without_its_keys_lists_the_keys_it_has_briefly(tmp_path: Path) -> None:
    """A HouseExpo file whose 'verts' key was renamed to a 6,000-character name listed every key
    whole: a 6 KB message."""
    import json

    (tmp_path / "h.json").write_text(json.dumps({"bbox": {"min": [0, 0], "max": [1, 1]}, "v" * 6000: [[0, 0]]}))
    with pytest.raises(ValueError, match=r"h\.json' has no 'verts' key \(keys: \['bbox', 'vvvv") as info:
        PlanMap.from_house_expo(tmp_path / "h.json")
    assert len(str(info.value)) < 300


@pytest.mark.parametrize(
    ("line", "key"),
    [
        ("plans: [{path: hall.png, resolution: 0.05, origin: [1, 2, BIG]}]", r"'plans\[0\]': origin"),
        ("plans: [default]\nfurniture: [BIG]", r"'furniture\[0\]': furniture"),
        ("plans: [default]\nsensors: {a: {range_max: BIG}}", r"'sensors\.a': range_max"),
    ],
)
def test_a_study_number_of_hundreds_of_digits_is_a_study_error(tmp_path: Path, line: str, key: str) -> None:
    """An integer of 400 digits where a float belongs raised OverflowError ("int too large to convert
    to float") from load_study."""
    (tmp_path / "s.yaml").write_text("name: x\n" + line.replace("BIG", "9" * 400) + "\n")
    with pytest.raises(StudyError, match=rf"key {key} is too large a number, got 9{{18}}\.\.\.9{{19}}"):
        load_study(tmp_path / "s.yaml")
