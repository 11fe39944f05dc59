from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast
from typing import Literal, cast






T = TypeVar("T", bound="LightDescType0")



@_attrs_define
class LightDescType0:
    """ Parallel light travelling along `direction`; `irradiance` in W/m² on a surface facing it.

        Attributes:
            direction (list[float]):
            irradiance (float | list[float]): A linear RGB triple that may be written as one number (grey) or `[r, g, b]`.
            type_ (Literal['directional']):
            angular_radius (float | Unset): Angular radius of the source's disc in degrees, 0..=10 (default 0: a delta
                light;
                the sun is 0.265). `irradiance` is the whole disc's. Default: 0.0.
     """

    direction: list[float]
    irradiance: float | list[float]
    type_: Literal['directional']
    angular_radius: float | Unset = 0.0





    def to_dict(self) -> dict[str, Any]:
        direction = self.direction



        irradiance: float | list[float]
        if isinstance(self.irradiance, list):
            irradiance = self.irradiance


        else:
            irradiance = self.irradiance

        type_ = self.type_

        angular_radius = self.angular_radius


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "direction": direction,
            "irradiance": irradiance,
            "type": type_,
        })
        if angular_radius is not UNSET:
            field_dict["angular_radius"] = angular_radius

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        direction = cast(list[float], d.pop("direction"))


        def _parse_irradiance(data: object) -> float | list[float]:
            try:
                if not isinstance(data, list):
                    raise TypeError()
                componentsschemas_rgb_type_1 = cast(list[float], data)

                return componentsschemas_rgb_type_1
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(float | list[float], data)

        irradiance = _parse_irradiance(d.pop("irradiance"))


        type_ = cast(Literal['directional'] , d.pop("type"))
        if type_ != 'directional':
            raise ValueError(f"type must match const 'directional', got '{type_}'")

        angular_radius = d.pop("angular_radius", UNSET)

        light_desc_type_0 = cls(
            direction=direction,
            irradiance=irradiance,
            type_=type_,
            angular_radius=angular_radius,
        )

        return light_desc_type_0

