from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import Literal, cast






T = TypeVar("T", bound="ShapeDescType6")



@_attrs_define
class ShapeDescType6:
    """ A glTF 2.0 file (`.glb` or `.gltf` with embedded data), resolved relative to the scene.

        Attributes:
            path (str):
            type_ (Literal['gltf']):
     """

    path: str
    type_: Literal['gltf']





    def to_dict(self) -> dict[str, Any]:
        path = self.path

        type_ = self.type_


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "path": path,
            "type": type_,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        path = d.pop("path")

        type_ = cast(Literal['gltf'] , d.pop("type"))
        if type_ != 'gltf':
            raise ValueError(f"type must match const 'gltf', got '{type_}'")

        shape_desc_type_6 = cls(
            path=path,
            type_=type_,
        )

        return shape_desc_type_6

