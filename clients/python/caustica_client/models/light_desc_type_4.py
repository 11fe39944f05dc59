from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast
from typing import Literal, cast






T = TypeVar("T", bound="LightDescType4")



@_attrs_define
class LightDescType4:
    """ Distant light from all directions: an equirectangular HDR image (`path`) or a constant
    `radiance`, multiplied by `scale`. Radiance in W/(m²·sr). The image is read as Mitsuba 3's
    `envmap`: the direction d towards the light is at u = atan2(d.x, -d.z)/2π (u = 0 at -Z,
    1/4 at +X), v = acos(d.y)/π, looked up bilinearly between texel centres at u = (i + 0.5)/W
    and v = j/(H - 1) (rows 0 and H - 1 on the poles).

        Attributes:
            type_ (Literal['environment']):
            path (None | str | Unset):
            radiance (float | list[float] | None | Unset):
            scale (float | Unset):  Default: 1.0.
     """

    type_: Literal['environment']
    path: None | str | Unset = UNSET
    radiance: float | list[float] | None | Unset = UNSET
    scale: float | Unset = 1.0





    def to_dict(self) -> dict[str, Any]:
        type_ = self.type_

        path: None | str | Unset
        if isinstance(self.path, Unset):
            path = UNSET
        else:
            path = self.path

        radiance: float | list[float] | None | Unset
        if isinstance(self.radiance, Unset):
            radiance = UNSET
        elif isinstance(self.radiance, list):
            radiance = self.radiance


        else:
            radiance = self.radiance

        scale = self.scale


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "type": type_,
        })
        if path is not UNSET:
            field_dict["path"] = path
        if radiance is not UNSET:
            field_dict["radiance"] = radiance
        if scale is not UNSET:
            field_dict["scale"] = scale

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        type_ = cast(Literal['environment'] , d.pop("type"))
        if type_ != 'environment':
            raise ValueError(f"type must match const 'environment', got '{type_}'")

        def _parse_path(data: object) -> None | str | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(None | str | Unset, data)

        path = _parse_path(d.pop("path", UNSET))


        def _parse_radiance(data: object) -> float | list[float] | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, list):
                    raise TypeError()
                componentsschemas_rgb_type_1 = cast(list[float], data)

                return componentsschemas_rgb_type_1
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(float | list[float] | None | Unset, data)

        radiance = _parse_radiance(d.pop("radiance", UNSET))


        scale = d.pop("scale", UNSET)

        light_desc_type_4 = cls(
            type_=type_,
            path=path,
            radiance=radiance,
            scale=scale,
        )

        return light_desc_type_4

