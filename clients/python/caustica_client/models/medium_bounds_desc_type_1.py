from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast
from typing import Literal, cast

if TYPE_CHECKING:
  from ..models.transform_desc import TransformDesc





T = TypeVar("T", bound="MediumBoundsDescType1")



@_attrs_define
class MediumBoundsDescType1:
    """ A box of `size` (metres, centred on the origin), placed by `transform`.

        Attributes:
            size (list[float]):
            type_ (Literal['box']):
            transform (TransformDesc | Unset): Translation, rotation and scale applied as T·R·S.
     """

    size: list[float]
    type_: Literal['box']
    transform: TransformDesc | Unset = UNSET





    def to_dict(self) -> dict[str, Any]:
        from ..models.transform_desc import TransformDesc # noqa: PLC0415
        size = self.size



        type_ = self.type_

        transform: dict[str, Any] | Unset = UNSET
        if not isinstance(self.transform, Unset):
            transform = self.transform.to_dict()


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "size": size,
            "type": type_,
        })
        if transform is not UNSET:
            field_dict["transform"] = transform

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.transform_desc import TransformDesc # noqa: PLC0415
        d = dict(src_dict)
        size = cast(list[float], d.pop("size"))


        type_ = cast(Literal['box'] , d.pop("type"))
        if type_ != 'box':
            raise ValueError(f"type must match const 'box', got '{type_}'")

        _transform = d.pop("transform", UNSET)
        transform: TransformDesc | Unset
        if isinstance(_transform,  Unset):
            transform = UNSET
        else:
            transform = TransformDesc.from_dict(_transform)




        medium_bounds_desc_type_1 = cls(
            size=size,
            type_=type_,
            transform=transform,
        )

        return medium_bounds_desc_type_1

