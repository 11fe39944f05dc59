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
  from ..models.shape_desc_type_0 import ShapeDescType0
  from ..models.shape_desc_type_1 import ShapeDescType1
  from ..models.shape_desc_type_2 import ShapeDescType2
  from ..models.shape_desc_type_3 import ShapeDescType3
  from ..models.shape_desc_type_4 import ShapeDescType4
  from ..models.shape_desc_type_5 import ShapeDescType5
  from ..models.shape_desc_type_6 import ShapeDescType6
  from ..models.shape_desc_type_7 import ShapeDescType7
  from ..models.transform_desc import TransformDesc





T = TypeVar("T", bound="MediumBoundsDescType2")



@_attrs_define
class MediumBoundsDescType2:
    """ The inside of a closed mesh: a `sphere`, `box`, `torus` or `cylinder` shape (as an
    object's), placed by `transform`. Only method `reference` renders it.

        Attributes:
            shape (ShapeDescType0 | ShapeDescType1 | ShapeDescType2 | ShapeDescType3 | ShapeDescType4 | ShapeDescType5 |
                ShapeDescType6 | ShapeDescType7): Geometry. Procedural shapes are centred at the origin in their local frame.
            type_ (Literal['mesh']):
            transform (TransformDesc | Unset): Translation, rotation and scale applied as T·R·S.
     """

    shape: ShapeDescType0 | ShapeDescType1 | ShapeDescType2 | ShapeDescType3 | ShapeDescType4 | ShapeDescType5 | ShapeDescType6 | ShapeDescType7
    type_: Literal['mesh']
    transform: TransformDesc | Unset = UNSET





    def to_dict(self) -> dict[str, Any]:
        from ..models.shape_desc_type_0 import ShapeDescType0 # noqa: PLC0415
        from ..models.shape_desc_type_1 import ShapeDescType1 # noqa: PLC0415
        from ..models.shape_desc_type_2 import ShapeDescType2 # noqa: PLC0415
        from ..models.shape_desc_type_3 import ShapeDescType3 # noqa: PLC0415
        from ..models.shape_desc_type_4 import ShapeDescType4 # noqa: PLC0415
        from ..models.shape_desc_type_5 import ShapeDescType5 # noqa: PLC0415
        from ..models.shape_desc_type_6 import ShapeDescType6 # noqa: PLC0415
        from ..models.shape_desc_type_7 import ShapeDescType7 # noqa: PLC0415
        from ..models.transform_desc import TransformDesc # noqa: PLC0415
        shape: dict[str, Any]
        if isinstance(self.shape, ShapeDescType0):
            shape = self.shape.to_dict()
        elif isinstance(self.shape, ShapeDescType1):
            shape = self.shape.to_dict()
        elif isinstance(self.shape, ShapeDescType2):
            shape = self.shape.to_dict()
        elif isinstance(self.shape, ShapeDescType3):
            shape = self.shape.to_dict()
        elif isinstance(self.shape, ShapeDescType4):
            shape = self.shape.to_dict()
        elif isinstance(self.shape, ShapeDescType5):
            shape = self.shape.to_dict()
        elif isinstance(self.shape, ShapeDescType6):
            shape = self.shape.to_dict()
        else:
            shape = self.shape.to_dict()


        type_ = self.type_

        transform: dict[str, Any] | Unset = UNSET
        if not isinstance(self.transform, Unset):
            transform = self.transform.to_dict()


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "shape": shape,
            "type": type_,
        })
        if transform is not UNSET:
            field_dict["transform"] = transform

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.shape_desc_type_0 import ShapeDescType0 # noqa: PLC0415
        from ..models.shape_desc_type_1 import ShapeDescType1 # noqa: PLC0415
        from ..models.shape_desc_type_2 import ShapeDescType2 # noqa: PLC0415
        from ..models.shape_desc_type_3 import ShapeDescType3 # noqa: PLC0415
        from ..models.shape_desc_type_4 import ShapeDescType4 # noqa: PLC0415
        from ..models.shape_desc_type_5 import ShapeDescType5 # noqa: PLC0415
        from ..models.shape_desc_type_6 import ShapeDescType6 # noqa: PLC0415
        from ..models.shape_desc_type_7 import ShapeDescType7 # noqa: PLC0415
        from ..models.transform_desc import TransformDesc # noqa: PLC0415
        d = dict(src_dict)
        def _parse_shape(data: object) -> ShapeDescType0 | ShapeDescType1 | ShapeDescType2 | ShapeDescType3 | ShapeDescType4 | ShapeDescType5 | ShapeDescType6 | ShapeDescType7:
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                componentsschemas_shape_desc_type_0 = ShapeDescType0.from_dict(data)



                return componentsschemas_shape_desc_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                componentsschemas_shape_desc_type_1 = ShapeDescType1.from_dict(data)



                return componentsschemas_shape_desc_type_1
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                componentsschemas_shape_desc_type_2 = ShapeDescType2.from_dict(data)



                return componentsschemas_shape_desc_type_2
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                componentsschemas_shape_desc_type_3 = ShapeDescType3.from_dict(data)



                return componentsschemas_shape_desc_type_3
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                componentsschemas_shape_desc_type_4 = ShapeDescType4.from_dict(data)



                return componentsschemas_shape_desc_type_4
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                componentsschemas_shape_desc_type_5 = ShapeDescType5.from_dict(data)



                return componentsschemas_shape_desc_type_5
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                componentsschemas_shape_desc_type_6 = ShapeDescType6.from_dict(data)



                return componentsschemas_shape_desc_type_6
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            if not isinstance(data, dict):
                raise TypeError()
            componentsschemas_shape_desc_type_7 = ShapeDescType7.from_dict(data)



            return componentsschemas_shape_desc_type_7

        shape = _parse_shape(d.pop("shape"))


        type_ = cast(Literal['mesh'] , d.pop("type"))
        if type_ != 'mesh':
            raise ValueError(f"type must match const 'mesh', got '{type_}'")

        _transform = d.pop("transform", UNSET)
        transform: TransformDesc | Unset
        if isinstance(_transform,  Unset):
            transform = UNSET
        else:
            transform = TransformDesc.from_dict(_transform)




        medium_bounds_desc_type_2 = cls(
            shape=shape,
            type_=type_,
            transform=transform,
        )

        return medium_bounds_desc_type_2

