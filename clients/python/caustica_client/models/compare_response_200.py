from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset







T = TypeVar("T", bound="CompareResponse200")



@_attrs_define
class CompareResponse200:
    """ 
        Attributes:
            flux_ratio (float):
            object_ (str):
            pixels (int): The pixels compared
            relative_l1 (float):
     """

    flux_ratio: float
    object_: str
    pixels: int
    relative_l1: float
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        flux_ratio = self.flux_ratio

        object_ = self.object_

        pixels = self.pixels

        relative_l1 = self.relative_l1


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "flux_ratio": flux_ratio,
            "object": object_,
            "pixels": pixels,
            "relative_l1": relative_l1,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        flux_ratio = d.pop("flux_ratio")

        object_ = d.pop("object")

        pixels = d.pop("pixels")

        relative_l1 = d.pop("relative_l1")

        compare_response_200 = cls(
            flux_ratio=flux_ratio,
            object_=object_,
            pixels=pixels,
            relative_l1=relative_l1,
        )


        compare_response_200.additional_properties = d
        return compare_response_200

    @property
    def additional_keys(self) -> list[str]:
        return list(self.additional_properties.keys())

    def __getitem__(self, key: str) -> Any:
        return self.additional_properties[key]

    def __setitem__(self, key: str, value: Any) -> None:
        self.additional_properties[key] = value

    def __delitem__(self, key: str) -> None:
        del self.additional_properties[key]

    def __contains__(self, key: str) -> bool:
        return key in self.additional_properties
