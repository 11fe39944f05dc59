from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast
from typing import Literal, cast






T = TypeVar("T", bound="LightDescType3")



@_attrs_define
class LightDescType3:
    """ A segment of isotropic emitters from `start` to `end`; `intensity` (W/sr) is the total,
    spread uniformly along the segment (a point light of that intensity when the segment
    shrinks to a point).

        Attributes:
            end (list[float]):
            intensity (float | list[float]): A linear RGB triple that may be written as one number (grey) or `[r, g, b]`.
            start (list[float]):
            type_ (Literal['line']):
     """

    end: list[float]
    intensity: float | list[float]
    start: list[float]
    type_: Literal['line']





    def to_dict(self) -> dict[str, Any]:
        end = self.end



        intensity: float | list[float]
        if isinstance(self.intensity, list):
            intensity = self.intensity


        else:
            intensity = self.intensity

        start = self.start



        type_ = self.type_


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "end": end,
            "intensity": intensity,
            "start": start,
            "type": type_,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        end = cast(list[float], d.pop("end"))


        def _parse_intensity(data: object) -> float | list[float]:
            try:
                if not isinstance(data, list):
                    raise TypeError()
                componentsschemas_rgb_type_1 = cast(list[float], data)

                return componentsschemas_rgb_type_1
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(float | list[float], data)

        intensity = _parse_intensity(d.pop("intensity"))


        start = cast(list[float], d.pop("start"))


        type_ = cast(Literal['line'] , d.pop("type"))
        if type_ != 'line':
            raise ValueError(f"type must match const 'line', got '{type_}'")

        light_desc_type_3 = cls(
            end=end,
            intensity=intensity,
            start=start,
            type_=type_,
        )

        return light_desc_type_3

