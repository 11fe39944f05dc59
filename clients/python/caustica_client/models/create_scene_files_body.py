from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field
import json
from .. import types

from ..types import UNSET, Unset

from ..types import File, FileTypes
from io import BytesIO
from typing import cast

if TYPE_CHECKING:
  from ..models.scene import Scene





T = TypeVar("T", bound="CreateSceneFilesBody")



@_attrs_define
class CreateSceneFilesBody:
    """ 
        Attributes:
            scene (Scene): A whole scene: one camera, the lights, named materials and objects.
     """

    scene: Scene
    additional_properties: dict[str, File] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.scene import Scene # noqa: PLC0415
        scene = self.scene.to_dict()


        field_dict: dict[str, Any] = {}
        for prop_name, prop in self.additional_properties.items():
            field_dict[prop_name] = prop.to_tuple()


        field_dict.update({
            "scene": scene,
        })

        return field_dict


    def to_multipart(self) -> types.RequestFiles:
        from ..models.scene import Scene # noqa: PLC0415
        files: types.RequestFiles = []

        files.append(("scene", (None, json.dumps( self.scene.to_dict()).encode(), "application/json")))




        for prop_name, prop in self.additional_properties.items():
            files.append((prop_name, prop.to_tuple()))



        return files


    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.scene import Scene # noqa: PLC0415
        d = dict(src_dict)
        scene = Scene.from_dict(d.pop("scene"))




        create_scene_files_body = cls(
            scene=scene,
        )


        additional_properties = {}
        for prop_name, prop_dict in d.items():
            additional_property = File(
                 payload = BytesIO(prop_dict)
            )



            additional_properties[prop_name] = additional_property

        create_scene_files_body.additional_properties = additional_properties
        return create_scene_files_body

    @property
    def additional_keys(self) -> list[str]:
        return list(self.additional_properties.keys())

    def __getitem__(self, key: str) -> File:
        return self.additional_properties[key]

    def __setitem__(self, key: str, value: File) -> None:
        self.additional_properties[key] = value

    def __delitem__(self, key: str) -> None:
        del self.additional_properties[key]

    def __contains__(self, key: str) -> bool:
        return key in self.additional_properties
