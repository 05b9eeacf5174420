"""One plan from whatever file a user has: the dispatch the command line shares."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .plan_map import CacheSetting, PlanMap


def house_expo_files(folder: str | Path) -> list[Path]:
    """The HouseExpo plans (`*.json`) directly in `folder`, sorted by name (a study's plan set).

    Raises:
        FileNotFoundError: `folder` does not exist.
        NotADirectoryError: it is a file.
        ValueError: it holds no `.json` file.
    """
    path = Path(folder)
    if not path.exists():
        raise FileNotFoundError(f"plan folder {path} does not exist")
    if not path.is_dir():
        raise NotADirectoryError(f"{path} is not a folder")
    files = sorted(p for p in path.iterdir() if p.suffix.lower() == ".json" and p.is_file())
    if not files:
        raise ValueError(f"plan folder {path} holds no HouseExpo .json file")
    return files


def load_plan(
    source: str | Path,
    *,
    resolution: float | None = None,
    origin: Sequence[float] = (0.0, 0.0, 0.0),
    cache: CacheSetting = True,
    spacing: float = 0.02,
    layers: Sequence[str] | None = None,
    **image_options: Any,
) -> PlanMap:
    """The plan in `source`, chosen by its suffix.

    * `.yaml`/`.yml`: a map_server map (its own resolution and origin);
    * `.json`: a HouseExpo plan: its outline sampled every `spacing` metres or, with `resolution`,
      rasterised at that many metres per pixel with 15 cm walls (a plan with a raster, as the
      simulation needs: `PlanMap.from_house_expo`);
    * `.dxf`: a CAD drawing (`layers`: the wall layers; needs `planicp[cad]`);
    * anything else: a plan image, which needs `resolution` (metres per pixel) and takes `origin`
      (x, y, yaw of the image's lower-left corner in the map frame) and `image_options`
      (`threshold`, `open_px`, `close_px`, `edge_detector`: see `PlanMap.from_image`).

    Raises:
        FileNotFoundError: `source` does not exist.
        ValueError: an image without a resolution, or a file the reader rejects.
    """
    path = Path(source)
    if not path.exists():
        raise FileNotFoundError(f"plan {path} does not exist")
    suffix = path.suffix.lower()
    if suffix in (".yaml", ".yml"):
        return PlanMap.from_ros_map(path, cache=cache)
    if suffix == ".json":
        return PlanMap.from_house_expo(path, spacing=spacing, resolution=resolution)
    if suffix == ".dxf":
        return PlanMap.from_dxf(path, list(layers) if layers else None, spacing=spacing)
    if resolution is None:
        raise ValueError(f"plan image {path} needs a resolution (metres per pixel, --resolution)")
    return PlanMap.from_image(path, resolution, tuple(origin), cache=cache, **image_options)
