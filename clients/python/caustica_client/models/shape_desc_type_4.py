from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import Literal, cast






T = TypeVar("T", bound="ShapeDescType4")



@_attrs_define
class ShapeDescType4:
    """ Capped cylinder along the local Y axis, from y=-height/2 to y=height/2.

        Attributes:
            height (float):
            radius (float):
            type_ (Literal['cylinder']):
            segments (int | Unset):  Default: 128.
     """

    height: float
    radius: float
    type_: Literal['cylinder']
    segments: int | Unset = 128





    def to_dict(self) -> dict[str, Any]:
        height = self.height

        radius = self.radius

        type_ = self.type_

        segments = self.segments


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "height": height,
            "radius": radius,
            "type": type_,
        })
        if segments is not UNSET:
            field_dict["segments"] = segments

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        height = d.pop("height")

        radius = d.pop("radius")

        type_ = cast(Literal['cylinder'] , d.pop("type"))
        if type_ != 'cylinder':
            raise ValueError(f"type must match const 'cylinder', got '{type_}'")

        segments = d.pop("segments", UNSET)

        shape_desc_type_4 = cls(
            height=height,
            radius=radius,
            type_=type_,
            segments=segments,
        )

        return shape_desc_type_4

