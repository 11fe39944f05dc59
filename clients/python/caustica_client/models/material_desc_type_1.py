from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast
from typing import Literal, cast






T = TypeVar("T", bound="MaterialDescType1")



@_attrs_define
class MaterialDescType1:
    """ Diffuse base plus a GGX specular lobe: f = albedo/π + D·G2·F / (4 cosθi cosθo), with
    α = roughness², height-correlated Smith G2 and Schlick Fresnel from `specular` (F0).

        Attributes:
            albedo (float | list[float]): A linear RGB triple that may be written as one number (grey) or `[r, g, b]`.
            roughness (float):
            type_ (Literal['glossy']):
            specular (float | list[float] | Unset): A linear RGB triple that may be written as one number (grey) or `[r, g,
                b]`.
     """

    albedo: float | list[float]
    roughness: float
    type_: Literal['glossy']
    specular: float | list[float] | Unset = UNSET





    def to_dict(self) -> dict[str, Any]:
        albedo: float | list[float]
        if isinstance(self.albedo, list):
            albedo = self.albedo


        else:
            albedo = self.albedo

        roughness = self.roughness

        type_ = self.type_

        specular: float | list[float] | Unset
        if isinstance(self.specular, Unset):
            specular = UNSET
        elif isinstance(self.specular, list):
            specular = self.specular


        else:
            specular = self.specular


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "albedo": albedo,
            "roughness": roughness,
            "type": type_,
        })
        if specular is not UNSET:
            field_dict["specular"] = specular

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


        roughness = d.pop("roughness")

        type_ = cast(Literal['glossy'] , d.pop("type"))
        if type_ != 'glossy':
            raise ValueError(f"type must match const 'glossy', got '{type_}'")

        def _parse_specular(data: object) -> float | list[float] | Unset:
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, list):
                    raise TypeError()
                componentsschemas_rgb_type_1 = cast(list[float], data)

                return componentsschemas_rgb_type_1
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(float | list[float] | Unset, data)

        specular = _parse_specular(d.pop("specular", UNSET))


        material_desc_type_1 = cls(
            albedo=albedo,
            roughness=roughness,
            type_=type_,
            specular=specular,
        )

        return material_desc_type_1

