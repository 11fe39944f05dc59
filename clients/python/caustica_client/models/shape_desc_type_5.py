from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import Literal, cast






T = TypeVar("T", bound="ShapeDescType5")



@_attrs_define
class ShapeDescType5:
    """ A paraboloid dish y = r²/(4·focal_length) around the local Y axis, r ≤ `radius`, open
    at the rim, normals on the concave side: light along −Y meets at its focus (0,
    focal_length, 0). `segments` around (rings = segments/2).

        Attributes:
            focal_length (float):
            radius (float):
            type_ (Literal['paraboloid']):
            segments (int | Unset):  Default: 128.
     """

    focal_length: float
    radius: float
    type_: Literal['paraboloid']
    segments: int | Unset = 128





    def to_dict(self) -> dict[str, Any]:
        focal_length = self.focal_length

        radius = self.radius

        type_ = self.type_

        segments = self.segments


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "focal_length": focal_length,
            "radius": radius,
            "type": type_,
        })
        if segments is not UNSET:
            field_dict["segments"] = segments

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        focal_length = d.pop("focal_length")

        radius = d.pop("radius")

        type_ = cast(Literal['paraboloid'] , d.pop("type"))
        if type_ != 'paraboloid':
            raise ValueError(f"type must match const 'paraboloid', got '{type_}'")

        segments = d.pop("segments", UNSET)

        shape_desc_type_5 = cls(
            focal_length=focal_length,
            radius=radius,
            type_=type_,
            segments=segments,
        )

        return shape_desc_type_5

