from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast






T = TypeVar("T", bound="CameraDesc")



@_attrs_define
class CameraDesc:
    """ Perspective pinhole camera.

        Attributes:
            eye (list[float]):
            target (list[float]):
            fov_y (float | Unset): Vertical field of view in degrees, (0, 180). Default: 40.0.
            height (int | Unset):  Default: 256.
            up (list[float] | Unset):
            width (int | Unset):  Default: 256.
     """

    eye: list[float]
    target: list[float]
    fov_y: float | Unset = 40.0
    height: int | Unset = 256
    up: list[float] | Unset = UNSET
    width: int | Unset = 256





    def to_dict(self) -> dict[str, Any]:
        eye = self.eye



        target = self.target



        fov_y = self.fov_y

        height = self.height

        up: list[float] | Unset = UNSET
        if not isinstance(self.up, Unset):
            up = self.up



        width = self.width


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "eye": eye,
            "target": target,
        })
        if fov_y is not UNSET:
            field_dict["fov_y"] = fov_y
        if height is not UNSET:
            field_dict["height"] = height
        if up is not UNSET:
            field_dict["up"] = up
        if width is not UNSET:
            field_dict["width"] = width

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        eye = cast(list[float], d.pop("eye"))


        target = cast(list[float], d.pop("target"))


        fov_y = d.pop("fov_y", UNSET)

        height = d.pop("height", UNSET)

        up = cast(list[float], d.pop("up", UNSET))


        width = d.pop("width", UNSET)

        camera_desc = cls(
            eye=eye,
            target=target,
            fov_y=fov_y,
            height=height,
            up=up,
            width=width,
        )

        return camera_desc

