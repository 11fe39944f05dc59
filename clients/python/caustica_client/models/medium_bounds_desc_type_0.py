from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import Literal, cast






T = TypeVar("T", bound="MediumBoundsDescType0")



@_attrs_define
class MediumBoundsDescType0:
    """ The whole scene: a box around every object, the camera and the lights, 1 % larger.

        Attributes:
            type_ (Literal['scene']):
     """

    type_: Literal['scene']





    def to_dict(self) -> dict[str, Any]:
        type_ = self.type_


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "type": type_,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        type_ = cast(Literal['scene'] , d.pop("type"))
        if type_ != 'scene':
            raise ValueError(f"type must match const 'scene', got '{type_}'")

        medium_bounds_desc_type_0 = cls(
            type_=type_,
        )

        return medium_bounds_desc_type_0

