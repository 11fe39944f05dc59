from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast

if TYPE_CHECKING:
  from ..models.material_desc_type_0 import MaterialDescType0
  from ..models.material_desc_type_1 import MaterialDescType1
  from ..models.material_desc_type_2 import MaterialDescType2
  from ..models.material_desc_type_3 import MaterialDescType3





T = TypeVar("T", bound="SceneMaterials")



@_attrs_define
class SceneMaterials:
    """ Materials by name; objects refer to them by that name.

     """

    additional_properties: dict[str, MaterialDescType0 | MaterialDescType1 | MaterialDescType2 | MaterialDescType3] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.material_desc_type_0 import MaterialDescType0 # noqa: PLC0415
        from ..models.material_desc_type_1 import MaterialDescType1 # noqa: PLC0415
        from ..models.material_desc_type_2 import MaterialDescType2 # noqa: PLC0415
        from ..models.material_desc_type_3 import MaterialDescType3 # noqa: PLC0415
        
        field_dict: dict[str, Any] = {}
        for prop_name, prop in self.additional_properties.items():
            
            if isinstance(prop, MaterialDescType0):
                field_dict[prop_name] = prop.to_dict()
            elif isinstance(prop, MaterialDescType1):
                field_dict[prop_name] = prop.to_dict()
            elif isinstance(prop, MaterialDescType2):
                field_dict[prop_name] = prop.to_dict()
            else:
                field_dict[prop_name] = prop.to_dict()



        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.material_desc_type_0 import MaterialDescType0 # noqa: PLC0415
        from ..models.material_desc_type_1 import MaterialDescType1 # noqa: PLC0415
        from ..models.material_desc_type_2 import MaterialDescType2 # noqa: PLC0415
        from ..models.material_desc_type_3 import MaterialDescType3 # noqa: PLC0415
        d = dict(src_dict)
        scene_materials = cls(
        )


        additional_properties = {}
        for prop_name, prop_dict in d.items():
            def _parse_additional_property(data: object) -> MaterialDescType0 | MaterialDescType1 | MaterialDescType2 | MaterialDescType3:
                try:
                    if not isinstance(data, dict):
                        raise TypeError()
                    componentsschemas_material_desc_type_0 = MaterialDescType0.from_dict(data)



                    return componentsschemas_material_desc_type_0
                except (TypeError, ValueError, AttributeError, KeyError):
                    pass
                try:
                    if not isinstance(data, dict):
                        raise TypeError()
                    componentsschemas_material_desc_type_1 = MaterialDescType1.from_dict(data)



                    return componentsschemas_material_desc_type_1
                except (TypeError, ValueError, AttributeError, KeyError):
                    pass
                try:
                    if not isinstance(data, dict):
                        raise TypeError()
                    componentsschemas_material_desc_type_2 = MaterialDescType2.from_dict(data)



                    return componentsschemas_material_desc_type_2
                except (TypeError, ValueError, AttributeError, KeyError):
                    pass
                if not isinstance(data, dict):
                    raise TypeError()
                componentsschemas_material_desc_type_3 = MaterialDescType3.from_dict(data)



                return componentsschemas_material_desc_type_3

            additional_property = _parse_additional_property(prop_dict)

            additional_properties[prop_name] = additional_property

        scene_materials.additional_properties = additional_properties
        return scene_materials

    @property
    def additional_keys(self) -> list[str]:
        return list(self.additional_properties.keys())

    def __getitem__(self, key: str) -> MaterialDescType0 | MaterialDescType1 | MaterialDescType2 | MaterialDescType3:
        return self.additional_properties[key]

    def __setitem__(self, key: str, value: MaterialDescType0 | MaterialDescType1 | MaterialDescType2 | MaterialDescType3) -> None:
        self.additional_properties[key] = value

    def __delitem__(self, key: str) -> None:
        del self.additional_properties[key]

    def __contains__(self, key: str) -> bool:
        return key in self.additional_properties
