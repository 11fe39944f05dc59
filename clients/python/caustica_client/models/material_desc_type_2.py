from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast
from typing import Literal, cast






T = TypeVar("T", bound="MaterialDescType2")



@_attrs_define
class MaterialDescType2:
    """ Smooth dielectric: index `ior` inside (1.0 outside), Fresnel-weighted reflection and
    refraction, and Beer-Lambert `absorption` (per metre, per channel) inside.

        Attributes:
            type_ (Literal['dielectric']):
            absorption (float | list[float] | Unset): A linear RGB triple that may be written as one number (grey) or `[r,
                g, b]`.
            ior (float | Unset):  Default: 1.5.
     """

    type_: Literal['dielectric']
    absorption: float | list[float] | Unset = UNSET
    ior: float | Unset = 1.5





    def to_dict(self) -> dict[str, Any]:
        type_ = self.type_

        absorption: float | list[float] | Unset
        if isinstance(self.absorption, Unset):
            absorption = UNSET
        elif isinstance(self.absorption, list):
            absorption = self.absorption


        else:
            absorption = self.absorption

        ior = self.ior


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "type": type_,
        })
        if absorption is not UNSET:
            field_dict["absorption"] = absorption
        if ior is not UNSET:
            field_dict["ior"] = ior

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        type_ = cast(Literal['dielectric'] , d.pop("type"))
        if type_ != 'dielectric':
            raise ValueError(f"type must match const 'dielectric', got '{type_}'")

        def _parse_absorption(data: object) -> float | list[float] | Unset:
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

        absorption = _parse_absorption(d.pop("absorption", UNSET))


        ior = d.pop("ior", UNSET)

        material_desc_type_2 = cls(
            type_=type_,
            absorption=absorption,
            ior=ior,
        )

        return material_desc_type_2

