from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast

if TYPE_CHECKING:
  from ..models.camera_desc import CameraDesc
  from ..models.light_desc_type_0 import LightDescType0
  from ..models.light_desc_type_1 import LightDescType1
  from ..models.light_desc_type_2 import LightDescType2
  from ..models.light_desc_type_3 import LightDescType3
  from ..models.light_desc_type_4 import LightDescType4
  from ..models.medium_desc import MediumDesc
  from ..models.object_desc import ObjectDesc
  from ..models.scene_materials import SceneMaterials





T = TypeVar("T", bound="Scene")



@_attrs_define
class Scene:
    """ A whole scene: one camera, the lights, named materials and objects.

        Attributes:
            camera (CameraDesc): Perspective pinhole camera.
            ground (bool | Unset): Adds a diffuse ground plane (albedo 0.6, named `ground`) under the objects, touching
                their lowest point: for a glass or mirror object with nothing under it to receive its
                shadow and caustic (default false).
            lights (list[LightDescType0 | LightDescType1 | LightDescType2 | LightDescType3 | LightDescType4] | Unset):
            materials (SceneMaterials | Unset): Materials by name; objects refer to them by that name.
            media (list[MediumDesc] | Unset): Participating media (fog): at most one, for now.
            name (str | Unset): Free text, shown in logs. Default: ''.
            objects (list[ObjectDesc] | Unset):
     """

    camera: CameraDesc
    ground: bool | Unset = UNSET
    lights: list[LightDescType0 | LightDescType1 | LightDescType2 | LightDescType3 | LightDescType4] | Unset = UNSET
    materials: SceneMaterials | Unset = UNSET
    media: list[MediumDesc] | Unset = UNSET
    name: str | Unset = ''
    objects: list[ObjectDesc] | Unset = UNSET





    def to_dict(self) -> dict[str, Any]:
        from ..models.camera_desc import CameraDesc # noqa: PLC0415
        from ..models.light_desc_type_0 import LightDescType0 # noqa: PLC0415
        from ..models.light_desc_type_1 import LightDescType1 # noqa: PLC0415
        from ..models.light_desc_type_2 import LightDescType2 # noqa: PLC0415
        from ..models.light_desc_type_3 import LightDescType3 # noqa: PLC0415
        from ..models.light_desc_type_4 import LightDescType4 # noqa: PLC0415
        from ..models.medium_desc import MediumDesc # noqa: PLC0415
        from ..models.object_desc import ObjectDesc # noqa: PLC0415
        from ..models.scene_materials import SceneMaterials # noqa: PLC0415
        camera = self.camera.to_dict()

        ground = self.ground

        lights: list[dict[str, Any]] | Unset = UNSET
        if not isinstance(self.lights, Unset):
            lights = []
            for lights_item_data in self.lights:
                lights_item: dict[str, Any]
                if isinstance(lights_item_data, LightDescType0):
                    lights_item = lights_item_data.to_dict()
                elif isinstance(lights_item_data, LightDescType1):
                    lights_item = lights_item_data.to_dict()
                elif isinstance(lights_item_data, LightDescType2):
                    lights_item = lights_item_data.to_dict()
                elif isinstance(lights_item_data, LightDescType3):
                    lights_item = lights_item_data.to_dict()
                else:
                    lights_item = lights_item_data.to_dict()

                lights.append(lights_item)



        materials: dict[str, Any] | Unset = UNSET
        if not isinstance(self.materials, Unset):
            materials = self.materials.to_dict()

        media: list[dict[str, Any]] | Unset = UNSET
        if not isinstance(self.media, Unset):
            media = []
            for media_item_data in self.media:
                media_item = media_item_data.to_dict()
                media.append(media_item)



        name = self.name

        objects: list[dict[str, Any]] | Unset = UNSET
        if not isinstance(self.objects, Unset):
            objects = []
            for objects_item_data in self.objects:
                objects_item = objects_item_data.to_dict()
                objects.append(objects_item)




        field_dict: dict[str, Any] = {}

        field_dict.update({
            "camera": camera,
        })
        if ground is not UNSET:
            field_dict["ground"] = ground
        if lights is not UNSET:
            field_dict["lights"] = lights
        if materials is not UNSET:
            field_dict["materials"] = materials
        if media is not UNSET:
            field_dict["media"] = media
        if name is not UNSET:
            field_dict["name"] = name
        if objects is not UNSET:
            field_dict["objects"] = objects

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.camera_desc import CameraDesc # noqa: PLC0415
        from ..models.light_desc_type_0 import LightDescType0 # noqa: PLC0415
        from ..models.light_desc_type_1 import LightDescType1 # noqa: PLC0415
        from ..models.light_desc_type_2 import LightDescType2 # noqa: PLC0415
        from ..models.light_desc_type_3 import LightDescType3 # noqa: PLC0415
        from ..models.light_desc_type_4 import LightDescType4 # noqa: PLC0415
        from ..models.medium_desc import MediumDesc # noqa: PLC0415
        from ..models.object_desc import ObjectDesc # noqa: PLC0415
        from ..models.scene_materials import SceneMaterials # noqa: PLC0415
        d = dict(src_dict)
        camera = CameraDesc.from_dict(d.pop("camera"))




        ground = d.pop("ground", UNSET)

        _lights = d.pop("lights", UNSET)
        lights: list[LightDescType0 | LightDescType1 | LightDescType2 | LightDescType3 | LightDescType4] | Unset = UNSET
        if _lights is not UNSET:
            lights = []
            for lights_item_data in _lights:
                def _parse_lights_item(data: object) -> LightDescType0 | LightDescType1 | LightDescType2 | LightDescType3 | LightDescType4:
                    try:
                        if not isinstance(data, dict):
                            raise TypeError()
                        componentsschemas_light_desc_type_0 = LightDescType0.from_dict(data)



                        return componentsschemas_light_desc_type_0
                    except (TypeError, ValueError, AttributeError, KeyError):
                        pass
                    try:
                        if not isinstance(data, dict):
                            raise TypeError()
                        componentsschemas_light_desc_type_1 = LightDescType1.from_dict(data)



                        return componentsschemas_light_desc_type_1
                    except (TypeError, ValueError, AttributeError, KeyError):
                        pass
                    try:
                        if not isinstance(data, dict):
                            raise TypeError()
                        componentsschemas_light_desc_type_2 = LightDescType2.from_dict(data)



                        return componentsschemas_light_desc_type_2
                    except (TypeError, ValueError, AttributeError, KeyError):
                        pass
                    try:
                        if not isinstance(data, dict):
                            raise TypeError()
                        componentsschemas_light_desc_type_3 = LightDescType3.from_dict(data)



                        return componentsschemas_light_desc_type_3
                    except (TypeError, ValueError, AttributeError, KeyError):
                        pass
                    if not isinstance(data, dict):
                        raise TypeError()
                    componentsschemas_light_desc_type_4 = LightDescType4.from_dict(data)



                    return componentsschemas_light_desc_type_4

                lights_item = _parse_lights_item(lights_item_data)

                lights.append(lights_item)


        _materials = d.pop("materials", UNSET)
        materials: SceneMaterials | Unset
        if isinstance(_materials,  Unset):
            materials = UNSET
        else:
            materials = SceneMaterials.from_dict(_materials)




        _media = d.pop("media", UNSET)
        media: list[MediumDesc] | Unset = UNSET
        if _media is not UNSET:
            media = []
            for media_item_data in _media:
                media_item = MediumDesc.from_dict(media_item_data)



                media.append(media_item)


        name = d.pop("name", UNSET)

        _objects = d.pop("objects", UNSET)
        objects: list[ObjectDesc] | Unset = UNSET
        if _objects is not UNSET:
            objects = []
            for objects_item_data in _objects:
                objects_item = ObjectDesc.from_dict(objects_item_data)



                objects.append(objects_item)


        scene = cls(
            camera=camera,
            ground=ground,
            lights=lights,
            materials=materials,
            media=media,
            name=name,
            objects=objects,
        )

        return scene

