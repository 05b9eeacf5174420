"""The settings a study combines, in study units: where a plan comes from (`PlanSource`), LIDAR models
(`SensorSetting`), odometry errors (`OdometrySetting`), and when a run succeeds (`SuccessCriterion`).

Each is a settings dataclass (`planicp._settings`): validated when made, read from a study file's
mappings by `planicp.sweep.study.Study.from_dict`. The simulation's models (`LidarModel`,
`OdometryNoise`, `ErrorGenerator`) check the values they take themselves.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Annotated, Any

from pydantic import AfterValidator, BeforeValidator, ValidationInfo
from pydantic.dataclasses import dataclass

from .._settings import SETTINGS, Flag, Real, Settings, Whole, refuse_value
from .._validation import brief
from ..sim.experiment import LidarModel
from ..sim.odometry import ErrorGenerator, OdometryNoise

__all__ = ["OdometrySetting", "PlanSource", "SensorSetting", "SuccessCriterion", "changed_fields"]

Number = Annotated[float, Real(finite=False)]
"""Any number (a float; text in a study file such as 1e-4 too): the simulation's models check their own."""


def _triple(value: Any, info: ValidationInfo) -> Any:
    if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple)) or len(value) != 3:
        refuse_value(f"{info.field_name} must be [x, y, yaw], got {brief(value)}")
    return value


Triple = Annotated[tuple[Number, Number, Number], BeforeValidator(_triple)]
"""(x, y, yaw): metres, metres, radians."""


def _finite(value: tuple[float, ...], info: ValidationInfo) -> tuple[float, ...]:
    if not all(math.isfinite(v) for v in value):
        refuse_value(f"{info.field_name} must be finite, got {brief(value)}")
    return value


def _path(value: Any) -> str:
    if not isinstance(value, str) or not value:
        refuse_value(f"path must be a non-empty string, got {brief(value)}")
    return value


@dataclass(frozen=True, config=SETTINGS)
class PlanSource(Settings):
    """Where a plan comes from.

    Attributes:
        path: "default" (the shipped office plan), a plan file (image, ROS map YAML, HouseExpo
            JSON) or a folder of HouseExpo JSON files, as written in the study (relative paths
            are relative to the study file).
        resolution: metres per pixel: required for plan images; for HouseExpo plans the
            rasterisation's (default 0.05); ignored for ROS maps.
        origin: (x, y, yaw) of a plan image's lower-left corner in the map frame (m, m, rad).
    """

    path: Annotated[str, BeforeValidator(_path)]
    resolution: Annotated[float, Real(gt=0.0, says="a positive number of metres per pixel")] | None = None
    origin: Annotated[Triple, AfterValidator(_finite)] = (0.0, 0.0, 0.0)

    def to_yaml(self) -> str | dict[str, Any]:
        """The YAML form: the bare path when nothing else is set."""
        if self.resolution is None and self.origin == (0.0, 0.0, 0.0):
            return self.path
        out: dict[str, Any] = {"path": self.path}
        if self.resolution is not None:
            out["resolution"] = self.resolution
        if self.origin != (0.0, 0.0, 0.0):
            out["origin"] = list(self.origin)
        return out


@dataclass(frozen=True, config=SETTINGS)
class SensorSetting(Settings):
    """A LIDAR model in study units (see `planicp.sim.experiment.LidarModel`).

    Attributes:
        fov_deg: field of view, degrees, centred on the laser's x axis.
        beams: beams per scan.
        range_min, range_max: valid range, metres.
        range_sigma: Gaussian range noise, metres.
        dropout: probability that a beam returns nothing.
        rate_hz: scans per second.
        mount: (x, y, yaw) of the laser in the robot's base frame (m, m, rad).
    """

    # The defaults are LidarModel's (a Hokuyo UTM-30LX-like scanner), in study units; LidarModel checks the values.
    fov_deg: Number = math.degrees(LidarModel.fov)
    beams: Annotated[int, Whole()] = LidarModel.beams
    range_min: Number = LidarModel.range_min
    range_max: Number = LidarModel.range_max
    range_sigma: Number = LidarModel.range_sigma
    dropout: Number = LidarModel.dropout
    rate_hz: Number = LidarModel.rate_hz
    mount: Triple = LidarModel.mount

    def __post_init__(self) -> None:
        self.lidar()  # LidarModel's checks

    def lidar(self) -> LidarModel:
        """The simulation's LIDAR model."""
        return LidarModel(
            fov=math.radians(self.fov_deg),
            beams=self.beams,
            range_min=self.range_min,
            range_max=self.range_max,
            range_sigma=self.range_sigma,
            dropout=self.dropout,
            rate_hz=self.rate_hz,
            mount=self.mount,
        )


@dataclass(frozen=True, config=SETTINGS)
class OdometrySetting(Settings):
    """Odometry errors (see `planicp.sim.odometry`): the thesis's constant error added to every
    message, Gaussian noise on every increment, and the message rate.

    Attributes:
        translation_per_message: metres added along +x to every message (5e-5).
        rotation_per_message: radians added to every message (5e-5).
        translation_fraction: noise sigma as a fraction of the step (0.01).
        rotation_fraction: noise sigma as a fraction of the rotation (0.01).
        rotation_sigma_min: constant rotation noise sigma, radians per message (1e-5).
        rate_hz: odometry messages per second (100); at least the LIDAR rate.
    """

    translation_per_message: Number = 5e-5
    rotation_per_message: Number = 5e-5
    translation_fraction: Number = 0.01
    rotation_fraction: Number = 0.01
    rotation_sigma_min: Number = 1e-5
    rate_hz: Annotated[float, Real(gt=0.0, says="a positive number of messages per second")] = 100.0

    def __post_init__(self) -> None:
        self.error_generator()  # the simulation's checks
        self.noise()

    def error_generator(self) -> ErrorGenerator:
        """The systematic error of every message."""
        return ErrorGenerator(self.translation_per_message, self.rotation_per_message)

    def noise(self) -> OdometryNoise:
        """The Gaussian noise of every increment."""
        return OdometryNoise(self.translation_fraction, self.rotation_fraction, self.rotation_sigma_min)

    @property
    def drift_deg_per_s(self) -> float:
        """Heading drift of the systematic error, degrees per second."""
        return math.degrees(self.rotation_per_message * self.rate_hz)

    @property
    def drift_mm_per_s(self) -> float:
        """Forward drift of the systematic error, millimetres per second."""
        return 1000.0 * self.translation_per_message * self.rate_hz


@dataclass(frozen=True, config=SETTINGS)
class SuccessCriterion(Settings):
    """When a run counts as a success: it finished, planicp's largest position error stayed below
    `max_position_error_m` metres, and (unless `allow_lost_at_end`) the localizer was not lost
    after the last scan."""

    max_position_error_m: Annotated[float, Real(gt=0.0, unit="metres")] = 0.3
    allow_lost_at_end: Flag = False


def changed_fields(setting: Any) -> dict[str, Any]:
    """The fields of a setting that differ from its defaults (so that the YAML stays short)."""
    default = type(setting)()
    out: dict[str, Any] = {}
    for f in dataclasses.fields(setting):
        value = getattr(setting, f.name)
        if value != getattr(default, f.name):
            out[f.name] = list(value) if isinstance(value, tuple) else value
    return out
