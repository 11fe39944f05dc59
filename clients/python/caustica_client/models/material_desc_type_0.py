from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast
from typing import Literal, cast






T = TypeVar("T", bound="MaterialDescType0")



@_attrs_define
class MaterialDescType0:
    """ Lambertian, BRDF albedo/π.

        Attributes:
            albedo (float | list[float]): A linear RGB triple that may be written as one number (grey) or `[r, g, b]`.
            type_ (Literal['diffuse']):
     """

    albedo: float | list[float]
    type_: Literal['diffuse']





    def to_dict(self) -> dict[str, Any]:
        albedo: float | list[float]
        if isinstance(self.albedo, list):
            albedo = self.albedo


        else:
            albedo = self.albedo

        type_ = self.type_


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "albedo": albedo,
            "type": type_,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        def _parse_albedo(data: object) -> float | list[float]:
            try:
                if not isinstance(data, list):
                    raise TypeError()
                componentsschemas_rgb_type_1 = cast(list[float], data)

                return componentsschemas_rgb_type_1
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(float | list[float], data)

        albedo = _parse_albedo(d.pop("albedo"))


        type_ = cast(Literal['diffuse'] , d.pop("type"))
        if type_ != 'diffuse':
            raise ValueError(f"type must match const 'diffuse', got '{type_}'")

        material_desc_type_0 = cls(
            albedo=albedo,
            type_=type_,
        )

        return material_desc_type_0

