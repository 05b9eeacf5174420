"""Settings: frozen pydantic dataclasses, validated once when made, whose errors name the field.

Every settings class of planicp (`IcpConfig`, the `Localizer`'s rules, the ROS node's parameters, a
sweep's study) is declared the same way, each constraint written once, in the field's annotation:

    @dataclass(frozen=True, config=SETTINGS)
    class OcclusionRule(Settings):
        margin: Annotated[float, Real(gt=0.0, unit="metres")] = 0.2
        beams: Annotated[int, Whole(ge=8, le=1 << 20)] = 1440

pydantic checks every value against its annotation when the object is made, and again when
`replace` makes a changed copy; nothing checks it afterwards, so reading a setting costs an
attribute access. (pydantic dataclasses rather than models: they keep what planicp's settings were,
frozen dataclasses made with positional or keyword arguments, whose assignment raises
`dataclasses.FrozenInstanceError`.)

The constraints keep planicp's conventions of what is refused and how:

- a number is an int or a float (numpy's too), never a bool or text; an integer is never a float;
  a flag is a bool, never 1 or "yes";
- a value of the wrong type is a TypeError naming the field, as Python refuses the wrong type; a
  value out of range is a `pydantic.ValidationError` (a ValueError) located at the field, whose
  message names the field, what it must be and the value;
- `from_dict` reads plain values (YAML, JSON, ROS parameters; nested settings as mappings): an
  unknown key is an error naming it and the known ones, and every refusal, wrong types too, is a
  ValidationError located at its key, so that a file's reader can say where (`first_error`, `key_path`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Annotated, Any, NoReturn, TypeVar

import numpy as np
from pydantic import BeforeValidator, ConfigDict, GetCoreSchemaHandler, TypeAdapter, ValidationError, ValidationInfo
from pydantic_core import PydanticCustomError, core_schema

from ._validation import as_pose, brief, one_line

__all__ = [
    "SETTINGS",
    "Flag",
    "Items",
    "Pose3",
    "Real",
    "Settings",
    "Whole",
    "first_error",
    "instance_of",
    "key_path",
    "non_empty",
    "read",
    "refuse_type",
    "refuse_value",
]

SETTINGS = ConfigDict(extra="forbid")
"""The pydantic configuration of every settings dataclass: an unknown keyword is an error."""

LOCATED = "planicp_located"
"""Key of the validation context in which every refusal is a ValidationError at its location (`read`)."""

NUMBER_TEXT = "planicp_number_text"
"""Key of the validation context in which a number may be text (`Real`): "1e-4", which PyYAML, a
YAML 1.1 reader, leaves a string."""

S = TypeVar("S", bound="Settings")


class Settings:
    """What every settings dataclass offers: a changed copy, and a round trip through plain values."""

    def replace(self: S, **changes: Any) -> S:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)  # type: ignore[type-var]  # (every Settings is a dataclass)

    def to_dict(self) -> dict[str, Any]:
        """Plain values (YAML/JSON friendly: nested settings as dicts, tuples as lists); `from_dict`
        reads them back."""
        values: dict[str, Any] = _plain(_adapter(type(self)).dump_python(self))
        return values

    @classmethod
    def from_dict(cls: type[S], values: Mapping[str, Any]) -> S:
        """The inverse of `to_dict`; missing keys keep their defaults, unknown keys are an error naming them."""
        return read(cls, values)


def read(cls: type[S], values: Any, *, what: str = "", context: Mapping[str, Any] | None = None) -> S:
    """`cls` from the mapping `values` (see `Settings.from_dict`).

    Raises:
        TypeError: `values` is not a mapping.
        ValueError: a key names no field of `cls` (`what`, e.g. "gate fields", says what the keys
            are; default: "<class> keys:").
        pydantic.ValidationError: a value is refused (a ValueError located at its key).
    """
    if not isinstance(values, Mapping):
        raise TypeError(f"{cls.__name__} settings must be a mapping of field names to values, got {brief(values)}")
    known = sorted(f.name for f in dataclasses.fields(cls) if f.init)  # type: ignore[arg-type]
    unknown = sorted(str(k) for k in values if k not in known)
    if unknown:
        raise ValueError(f"unknown {what or cls.__name__ + ' keys:'} {brief(unknown)}; known: {known}")
    return _adapter(cls).validate_python(dict(values), context={LOCATED: True, **(context or {})})


_ADAPTERS: dict[type[Any], TypeAdapter[Any]] = {}


def _adapter(cls: type[S]) -> TypeAdapter[S]:
    """pydantic's validator and serializer of `cls`, made once."""
    adapter = _ADAPTERS.get(cls)
    if adapter is None:
        adapter = _ADAPTERS[cls] = TypeAdapter(cls)
    return adapter


def _plain(value: Any) -> Any:
    """`value` with its tuples made lists, through dicts and lists."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def first_error(error: ValidationError) -> str:
    """The first refusal of a ValidationError, on one line: its message, after its key path
    (`search.resolution: ...`) unless the message starts with the key."""
    e = error.errors(include_url=False)[0]
    message = one_line(e["msg"].removeprefix("Value error, "), 300)
    loc = e["loc"]
    if not loc or message.startswith(str(loc[-1])):
        return message
    return f"{key_path(loc)}: {message}"


def key_path(loc: Sequence[int | str]) -> str:
    """A ValidationError's location as a key path: `plans[0].origin`, `sensors.budget.beams`."""
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text


# --------------------------------------------------------------------------------------------------
# Constraints: pydantic metadata of a field's annotation
# --------------------------------------------------------------------------------------------------


def refuse_type(info: ValidationInfo, message: str) -> NoReturn:
    """Refuses a value of the wrong type: a TypeError, or (reading a mapping, `read`) a
    ValidationError at its location."""
    if info.context is not None and info.context.get(LOCATED):
        raise PydanticCustomError("wrong_type", "{message}", {"message": message})
    raise TypeError(message)


def refuse_value(message: str) -> NoReturn:
    """Refuses a value out of range: a ValidationError (a ValueError) at its location."""
    raise PydanticCustomError("invalid_value", "{message}", {"message": message})


def _subject(info: ValidationInfo, name: str) -> str:
    return name or info.field_name or "value"


@dataclasses.dataclass(frozen=True)
class Real:
    """A real number (an int or float, numpy's too; never a bool or text), made a float, within
    bounds: `Annotated[float, Real(gt=0.0, unit="metres")]`.

    Attributes:
        gt, ge, lt, le: the bounds (None: unbounded).
        finite: refuse NaN and infinities (NaN is refused by any bound).
        unit: said after the number in a message ("metres").
        note: said at the end of a message ("(0 disables it)").
        says: what the value "must be", instead of the message made from the bounds.
        name: the value's name in messages (default: the field's).
    """

    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None
    finite: bool = True
    unit: str = ""
    note: str = ""
    says: str = ""
    name: str = ""

    def __get_pydantic_core_schema__(self, source: Any, handler: GetCoreSchemaHandler) -> core_schema.CoreSchema:
        inner = core_schema.float_schema(gt=self.gt, ge=self.ge, lt=self.lt, le=self.le, allow_inf_nan=not self.finite)
        return core_schema.with_info_before_validator_function(self.validate, inner)

    def validate(self, value: Any, info: ValidationInfo) -> float:
        """`value` as a float; refused (see `refuse_type`, `refuse_value`) when it is not a number or out of bounds."""
        name = _subject(info, self.name)
        if isinstance(value, str) and info.context is not None and info.context.get(NUMBER_TEXT):
            value = _number_text(value)
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
            refuse_type(info, f"{name} must be a number, got {type(value).__name__} {brief(value)}")
        try:
            v = float(value)
        except OverflowError:  # an int of hundreds of digits
            refuse_value(f"{name} is too large a number, got {brief(value)}")
        if not self._within(v):
            refuse_value(f"{name} must be {self.says or self._range()}, got {brief(value)}")
        return v

    def _within(self, v: float) -> bool:
        if math.isnan(v):  # within no bounds
            return not self.finite and self.gt is None and self.ge is None and self.lt is None and self.le is None
        return (
            (not self.finite or math.isfinite(v))
            and (self.gt is None or v > self.gt)
            and (self.ge is None or v >= self.ge)
            and (self.lt is None or v < self.lt)
            and (self.le is None or v <= self.le)
        )

    def _range(self) -> str:
        low, high = _first(self.gt, self.ge), _first(self.lt, self.le)
        unit = f" {self.unit}" if self.unit else ""
        note = f" {self.note}" if self.note else ""
        if low is not None and high is not None:
            opening, closing = "(" if self.gt is not None else "[", ")" if self.lt is not None else "]"
            return f"in {opening}{low:g}, {high:g}{closing}{unit}{note}"
        finite = "finite " if self.finite else ""
        if self.gt == 0.0 and high is None:
            return f"a positive {finite}number{' of ' + self.unit if self.unit else ''}{note}"
        if low is not None:
            return f"a {finite}number {'>' if self.gt is not None else '>='} {low:g}{unit}{note}"
        if high is not None:
            return f"a {finite}number {'<' if self.lt is not None else '<='} {high:g}{unit}{note}"
        return f"a {finite}number{unit}{note}"


def _first(a: float | None, b: float | None) -> float | None:
    return a if a is not None else b


def _number_text(text: str) -> Any:
    """A number written as text, as a float ("1e-4"); other text as it is."""
    try:
        return float(text)
    except ValueError:
        return text


@dataclasses.dataclass(frozen=True)
class Whole:
    """An integer (an int, numpy's too; never a bool or float) within [`ge`, `le`]:
    `Annotated[int, Whole(ge=1)]`. `le` defaults to the largest 32-bit int, which the native
    core takes for any count."""

    ge: int = 0
    le: int = 2**31 - 1
    name: str = ""

    def __get_pydantic_core_schema__(self, source: Any, handler: GetCoreSchemaHandler) -> core_schema.CoreSchema:
        return core_schema.with_info_before_validator_function(
            self.validate, core_schema.int_schema(ge=self.ge, le=self.le)
        )

    def validate(self, value: Any, info: ValidationInfo) -> int:
        """`value` as an int; refused when it is not an integer or out of bounds."""
        name = _subject(info, self.name)
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            refuse_type(info, f"{name} must be an integer, got {type(value).__name__} {brief(value)}")
        if value < self.ge:
            refuse_value(f"{name} must be at least {self.ge}, got {brief(value)}")
        if value > self.le:
            refuse_value(f"{name} must be at most {self.le}, got {brief(value)}")
        return int(value)


def _flag(value: Any, info: ValidationInfo) -> bool:
    if not isinstance(value, bool):
        refuse_type(info, f"{info.field_name} must be a bool (true or false), got {brief(value)}")
    return value


Flag = Annotated[bool, BeforeValidator(_flag)]
"""A bool, never 1 or "yes"."""


def _sequence(value: Any, info: ValidationInfo) -> tuple[Any, ...]:
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence):
        refuse_type(info, f"{info.field_name} must be a sequence, got {brief(value)}")
    return tuple(value)


Items = BeforeValidator(_sequence)
"""Metadata of a tuple field: a list or a tuple (any sequence but text), never a set, an array or a
single value."""


def non_empty(what: str) -> BeforeValidator:
    """Metadata of a sequence field that needs at least one item: `what` says what they are."""

    def check(value: Any, info: ValidationInfo) -> Any:
        if isinstance(value, Sequence) and not isinstance(value, (str, bytes)) and len(value) == 0:
            refuse_value(f"{info.field_name} needs at least one {what}")
        return value

    return BeforeValidator(check)


def _pose(value: Any, info: ValidationInfo) -> tuple[float, float, float]:
    try:
        return as_pose(value, info.field_name or "pose")
    except TypeError as exc:
        refuse_type(info, str(exc))
    except ValueError as exc:
        refuse_value(str(exc))


Pose3 = Annotated[tuple[float, float, float], BeforeValidator(_pose)]
"""A finite (x, y, yaw) of three numbers (metres, metres, radians), a tuple of floats."""


def instance_of(cls: type[Any], label: str = "") -> BeforeValidator:
    """Metadata of a field whose value is a `cls` (`label` names it in messages): an instance, not
    validated again; only when a mapping is read (`read`) may it be a mapping of its fields."""

    def check(value: Any, info: ValidationInfo) -> Any:
        if isinstance(value, cls):
            return value
        if isinstance(value, Mapping) and info.context is not None and info.context.get(LOCATED):
            return value
        refuse_type(info, f"{info.field_name} must be a {label or cls.__name__}, got {type(value).__name__}")

    return BeforeValidator(check)
