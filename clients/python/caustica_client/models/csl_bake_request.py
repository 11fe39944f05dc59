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
  from ..models.csl_params import CslParams
  from ..models.scene import Scene





T = TypeVar("T", bound="CslBakeRequest")



@_attrs_define
class CslBakeRequest:
    """ Caustic spot lights (Liu et al. 2008) of the object for the scene's first directional
    light, or with `dynamic` for every direction; the artifact is the checksummed CSL set
    of `caustica bake csl`.

        Attributes:
            method (Literal['csl']):
            object_ (str): The name of the object the bake is for.
            params (CslParams | None | Unset):
            scene (None | Scene | str | Unset):
            scene_id (None | str | Unset): The id of a stored scene (the same as giving the id as `scene`).
     """

    method: Literal['csl']
    object_: str
    params: CslParams | None | Unset = UNSET
    scene: None | Scene | str | Unset = UNSET
    scene_id: None | str | Unset = UNSET





    def to_dict(self) -> dict[str, Any]:
        from ..models.csl_params import CslParams # noqa: PLC0415
        from ..models.scene import Scene # noqa: PLC0415
        method = self.method

        object_ = self.object_

        params: dict[str, Any] | None | Unset
        if isinstance(self.params, Unset):
            params = UNSET
        elif isinstance(self.params, CslParams):
            params = self.params.to_dict()
        else:
            params = self.params

        scene: dict[str, Any] | None | str | Unset
        if isinstance(self.scene, Unset):
            scene = UNSET
        elif isinstance(self.scene, Scene):
            scene = self.scene.to_dict()
        else:
            scene = self.scene

        scene_id: None | str | Unset
        if isinstance(self.scene_id, Unset):
            scene_id = UNSET
        else:
            scene_id = self.scene_id


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "method": method,
            "object": object_,
        })
        if params is not UNSET:
            field_dict["params"] = params
        if scene is not UNSET:
            field_dict["scene"] = scene
        if scene_id is not UNSET:
            field_dict["scene_id"] = scene_id

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.csl_params import CslParams # noqa: PLC0415
        from ..models.scene import Scene # noqa: PLC0415
        d = dict(src_dict)
        method = cast(Literal['csl'] , d.pop("method"))
        if method != 'csl':
            raise ValueError(f"method must match const 'csl', got '{method}'")

        object_ = d.pop("object")

        def _parse_params(data: object) -> CslParams | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                params_type_0 = CslParams.from_dict(data)



                return params_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(CslParams | None | Unset, data)

        params = _parse_params(d.pop("params", UNSET))


        def _parse_scene(data: object) -> None | Scene | str | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                componentsschemas_scene_ref_type_0 = Scene.from_dict(data)



                return componentsschemas_scene_ref_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(None | Scene | str | Unset, data)

        scene = _parse_scene(d.pop("scene", UNSET))


        def _parse_scene_id(data: object) -> None | str | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(None | str | Unset, data)

        scene_id = _parse_scene_id(d.pop("scene_id", UNSET))


        csl_bake_request = cls(
            method=method,
            object_=object_,
            params=params,
            scene=scene,
            scene_id=scene_id,
        )

        return csl_bake_request

