from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast

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





T = TypeVar("T", bound="ObjectDesc")



@_attrs_define
class ObjectDesc:
    """ One object: a shape, a material and a transform.

        Attributes:
            name (str): Unique name; bakes and renders refer to objects by it.
            shape (ShapeDescType0 | ShapeDescType1 | ShapeDescType2 | ShapeDescType3 | ShapeDescType4 | ShapeDescType5 |
                ShapeDescType6 | ShapeDescType7): Geometry. Procedural shapes are centred at the origin in their local frame.
            material (None | str | Unset): Name of an entry of `materials`. Required for procedural shapes; for glTF it
                overrides
                the file's materials when given.
            transform (TransformDesc | Unset): Translation, rotation and scale applied as T·R·S.
     """

    name: str
    shape: ShapeDescType0 | ShapeDescType1 | ShapeDescType2 | ShapeDescType3 | ShapeDescType4 | ShapeDescType5 | ShapeDescType6 | ShapeDescType7
    material: None | str | Unset = UNSET
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
        name = self.name

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


        material: None | str | Unset
        if isinstance(self.material, Unset):
            material = UNSET
        else:
            material = self.material

        transform: dict[str, Any] | Unset = UNSET
        if not isinstance(self.transform, Unset):
            transform = self.transform.to_dict()


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "name": name,
            "shape": shape,
        })
        if material is not UNSET:
            field_dict["material"] = material
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
        name = d.pop("name")

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


        def _parse_material(data: object) -> None | str | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(None | str | Unset, data)

        material = _parse_material(d.pop("material", UNSET))


        _transform = d.pop("transform", UNSET)
        transform: TransformDesc | Unset
        if isinstance(_transform,  Unset):
            transform = UNSET
        else:
            transform = TransformDesc.from_dict(_transform)




        object_desc = cls(
            name=name,
            shape=shape,
            material=material,
            transform=transform,
        )

        return object_desc

