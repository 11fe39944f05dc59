from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import Literal, cast






T = TypeVar("T", bound="ShapeDescType3")



@_attrs_define
class ShapeDescType3:
    """ Torus around the local Y axis.

        Attributes:
            major_radius (float):
            minor_radius (float):
            type_ (Literal['torus']):
            segments (int | Unset):  Default: 128.
     """

    major_radius: float
    minor_radius: float
    type_: Literal['torus']
    segments: int | Unset = 128





    def to_dict(self) -> dict[str, Any]:
        major_radius = self.major_radius

        minor_radius = self.minor_radius

        type_ = self.type_

        segments = self.segments


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "major_radius": major_radius,
            "minor_radius": minor_radius,
            "type": type_,
        })
        if segments is not UNSET:
            field_dict["segments"] = segments

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        major_radius = d.pop("major_radius")

        minor_radius = d.pop("minor_radius")

        type_ = cast(Literal['torus'] , d.pop("type"))
        if type_ != 'torus':
            raise ValueError(f"type must match const 'torus', got '{type_}'")

        segments = d.pop("segments", UNSET)

        shape_desc_type_3 = cls(
            major_radius=major_radius,
            minor_radius=minor_radius,
            type_=type_,
            segments=segments,
        )

        return shape_desc_type_3

