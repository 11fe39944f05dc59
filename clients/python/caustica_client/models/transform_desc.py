from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast






T = TypeVar("T", bound="TransformDesc")



@_attrs_define
class TransformDesc:
    """ Translation, rotation and scale applied as T·R·S.

        Attributes:
            rotation_deg (list[float] | None | Unset): Rotation as Euler angles in degrees, applied about X, then Y, then Z.
            scale (float | list[float] | None | Unset): Uniform (one number) or per-axis scale.
            translation (list[float] | None | Unset):
     """

    rotation_deg: list[float] | None | Unset = UNSET
    scale: float | list[float] | None | Unset = UNSET
    translation: list[float] | None | Unset = UNSET





    def to_dict(self) -> dict[str, Any]:
        rotation_deg: list[float] | None | Unset
        if isinstance(self.rotation_deg, Unset):
            rotation_deg = UNSET
        elif isinstance(self.rotation_deg, list):
            rotation_deg = self.rotation_deg


        else:
            rotation_deg = self.rotation_deg

        scale: float | list[float] | None | Unset
        if isinstance(self.scale, Unset):
            scale = UNSET
        elif isinstance(self.scale, list):
            scale = self.scale


        else:
            scale = self.scale

        translation: list[float] | None | Unset
        if isinstance(self.translation, Unset):
            translation = UNSET
        elif isinstance(self.translation, list):
            translation = self.translation


        else:
            translation = self.translation


        field_dict: dict[str, Any] = {}

        field_dict.update({
        })
        if rotation_deg is not UNSET:
            field_dict["rotation_deg"] = rotation_deg
        if scale is not UNSET:
            field_dict["scale"] = scale
        if translation is not UNSET:
            field_dict["translation"] = translation

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        def _parse_rotation_deg(data: object) -> list[float] | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, list):
                    raise TypeError()
                rotation_deg_type_0 = cast(list[float], data)

                return rotation_deg_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(list[float] | None | Unset, data)

        rotation_deg = _parse_rotation_deg(d.pop("rotation_deg", UNSET))


        def _parse_scale(data: object) -> float | list[float] | None | Unset:
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

        scale = _parse_scale(d.pop("scale", UNSET))


        def _parse_translation(data: object) -> list[float] | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, list):
                    raise TypeError()
                translation_type_0 = cast(list[float], data)

                return translation_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(list[float] | None | Unset, data)

        translation = _parse_translation(d.pop("translation", UNSET))


        transform_desc = cls(
            rotation_deg=rotation_deg,
            scale=scale,
            translation=translation,
        )

        return transform_desc

