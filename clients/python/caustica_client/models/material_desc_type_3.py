from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast
from typing import Literal, cast






T = TypeVar("T", bound="MaterialDescType3")



@_attrs_define
class MaterialDescType3:
    """ Perfect specular reflector with reflectance `reflectance`.

        Attributes:
            type_ (Literal['mirror']):
            reflectance (float | list[float] | Unset): A linear RGB triple that may be written as one number (grey) or `[r,
                g, b]`.
     """

    type_: Literal['mirror']
    reflectance: float | list[float] | Unset = UNSET





    def to_dict(self) -> dict[str, Any]:
        type_ = self.type_

        reflectance: float | list[float] | Unset
        if isinstance(self.reflectance, Unset):
            reflectance = UNSET
        elif isinstance(self.reflectance, list):
            reflectance = self.reflectance


        else:
            reflectance = self.reflectance


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "type": type_,
        })
        if reflectance is not UNSET:
            field_dict["reflectance"] = reflectance

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        type_ = cast(Literal['mirror'] , d.pop("type"))
        if type_ != 'mirror':
            raise ValueError(f"type must match const 'mirror', got '{type_}'")

        def _parse_reflectance(data: object) -> float | list[float] | Unset:
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

        reflectance = _parse_reflectance(d.pop("reflectance", UNSET))


        material_desc_type_3 = cls(
            type_=type_,
            reflectance=reflectance,
        )

        return material_desc_type_3

