from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset






T = TypeVar("T", bound="CompareBody")



@_attrs_define
class CompareBody:
    """ 
        Attributes:
            a (str): The id of the render measured (rn_…)
            b (str): The id of the render it is measured against
            object_ (str | Unset): The object whose pixels count Default: 'floor'.
     """

    a: str
    b: str
    object_: str | Unset = 'floor'





    def to_dict(self) -> dict[str, Any]:
        a = self.a

        b = self.b

        object_ = self.object_


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "a": a,
            "b": b,
        })
        if object_ is not UNSET:
            field_dict["object"] = object_

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        a = d.pop("a")

        b = d.pop("b")

        object_ = d.pop("object", UNSET)

        compare_body = cls(
            a=a,
            b=b,
            object_=object_,
        )

        return compare_body

