from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast
from typing import Literal, cast






T = TypeVar("T", bound="ShapeDescType0")



@_attrs_define
class ShapeDescType0:
    """ Rectangle in the local y=0 plane, normal +Y, `size` = [x extent, z extent].

        Attributes:
            size (list[float]):
            type_ (Literal['plane']):
     """

    size: list[float]
    type_: Literal['plane']





    def to_dict(self) -> dict[str, Any]:
        size = self.size



        type_ = self.type_


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "size": size,
            "type": type_,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        size = cast(list[float], d.pop("size"))


        type_ = cast(Literal['plane'] , d.pop("type"))
        if type_ != 'plane':
            raise ValueError(f"type must match const 'plane', got '{type_}'")

        shape_desc_type_0 = cls(
            size=size,
            type_=type_,
        )

        return shape_desc_type_0

