from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast

if TYPE_CHECKING:
  from ..models.method_fit import MethodFit
  from ..models.object_info import ObjectInfo
  from ..models.scene_info_scene import SceneInfoScene





T = TypeVar("T", bound="SceneInfo")



@_attrs_define
class SceneInfo:
    """ What a client learns about a stored scene.

        Attributes:
            files (list[str]): The files the scene names (multipart uploads).
            id (str): SHA-256 of the canonical scene and its files.
            lights (list[str]):
            methods (list[MethodFit]): Each method: whether it renders this scene, and why or why not.
            name (str):
            objects (list[ObjectInfo]):
            scene (SceneInfoScene): The canonical scene description.
            triangles (int):
            warnings (list[str]): What the upload left out or assumed (a glTF without a camera, say).
     """

    files: list[str]
    id: str
    lights: list[str]
    methods: list[MethodFit]
    name: str
    objects: list[ObjectInfo]
    scene: SceneInfoScene
    triangles: int
    warnings: list[str]
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.method_fit import MethodFit # noqa: PLC0415
        from ..models.object_info import ObjectInfo # noqa: PLC0415
        from ..models.scene_info_scene import SceneInfoScene # noqa: PLC0415
        files = self.files



        id = self.id

        lights = self.lights



        methods = []
        for methods_item_data in self.methods:
            methods_item = methods_item_data.to_dict()
            methods.append(methods_item)



        name = self.name

        objects = []
        for objects_item_data in self.objects:
            objects_item = objects_item_data.to_dict()
            objects.append(objects_item)



        scene = self.scene.to_dict()

        triangles = self.triangles

        warnings = self.warnings




        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "files": files,
            "id": id,
            "lights": lights,
            "methods": methods,
            "name": name,
            "objects": objects,
            "scene": scene,
            "triangles": triangles,
            "warnings": warnings,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.method_fit import MethodFit # noqa: PLC0415
        from ..models.object_info import ObjectInfo # noqa: PLC0415
        from ..models.scene_info_scene import SceneInfoScene # noqa: PLC0415
        d = dict(src_dict)
        files = cast(list[str], d.pop("files"))


        id = d.pop("id")

        lights = cast(list[str], d.pop("lights"))


        methods = []
        _methods = d.pop("methods")
        for methods_item_data in (_methods):
            methods_item = MethodFit.from_dict(methods_item_data)



            methods.append(methods_item)


        name = d.pop("name")

        objects = []
        _objects = d.pop("objects")
        for objects_item_data in (_objects):
            objects_item = ObjectInfo.from_dict(objects_item_data)



            objects.append(objects_item)


        scene = SceneInfoScene.from_dict(d.pop("scene"))




        triangles = d.pop("triangles")

        warnings = cast(list[str], d.pop("warnings"))


        scene_info = cls(
            files=files,
            id=id,
            lights=lights,
            methods=methods,
            name=name,
            objects=objects,
            scene=scene,
            triangles=triangles,
            warnings=warnings,
        )


        scene_info.additional_properties = d
        return scene_info

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
