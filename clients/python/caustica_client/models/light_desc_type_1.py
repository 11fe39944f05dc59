from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast
from typing import Literal, cast






T = TypeVar("T", bound="LightDescType1")



@_attrs_define
class LightDescType1:
    """ Isotropic point light; `intensity` in W/sr.

        Attributes:
            intensity (float | list[float]): A linear RGB triple that may be written as one number (grey) or `[r, g, b]`.
            position (list[float]):
            type_ (Literal['point']):
     """

    intensity: float | list[float]
    position: list[float]
    type_: Literal['point']





    def to_dict(self) -> dict[str, Any]:
        intensity: float | list[float]
        if isinstance(self.intensity, list):
            intensity = self.intensity


        else:
            intensity = self.intensity

        position = self.position



        type_ = self.type_


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "intensity": intensity,
            "position": position,
            "type": type_,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
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


        position = cast(list[float], d.pop("position"))


        type_ = cast(Literal['point'] , d.pop("type"))
        if type_ != 'point':
            raise ValueError(f"type must match const 'point', got '{type_}'")

        light_desc_type_1 = cls(
            intensity=intensity,
            position=position,
            type_=type_,
        )

        return light_desc_type_1

