from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import Literal, cast






T = TypeVar("T", bound="ShapeDescType1")



@_attrs_define
class ShapeDescType1:
    """ UV sphere with smooth normals; `segments` around the equator (rings = segments/2).

        Attributes:
            radius (float):
            type_ (Literal['sphere']):
            segments (int | Unset):  Default: 128.
     """

    radius: float
    type_: Literal['sphere']
    segments: int | Unset = 128





    def to_dict(self) -> dict[str, Any]:
        radius = self.radius

        type_ = self.type_

        segments = self.segments


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "radius": radius,
            "type": type_,
        })
        if segments is not UNSET:
            field_dict["segments"] = segments

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        radius = d.pop("radius")

        type_ = cast(Literal['sphere'] , d.pop("type"))
        if type_ != 'sphere':
            raise ValueError(f"type must match const 'sphere', got '{type_}'")

        segments = d.pop("segments", UNSET)

        shape_desc_type_1 = cls(
            radius=radius,
            type_=type_,
            segments=segments,
        )

        return shape_desc_type_1

