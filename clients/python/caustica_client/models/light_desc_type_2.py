from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast
from typing import Literal, cast






T = TypeVar("T", bound="LightDescType2")



@_attrs_define
class LightDescType2:
    """ Spot light at `position` aimed at `target`; `intensity` in W/sr on the axis, full
    intensity inside `beam_width` (degrees from the axis), falling linearly in angle to zero
    at `cutoff_angle` (Mitsuba's `spot`).

        Attributes:
            intensity (float | list[float]): A linear RGB triple that may be written as one number (grey) or `[r, g, b]`.
            position (list[float]):
            target (list[float]):
            type_ (Literal['spot']):
            beam_width (float | Unset):  Default: 15.0.
            cutoff_angle (float | Unset):  Default: 20.0.
     """

    intensity: float | list[float]
    position: list[float]
    target: list[float]
    type_: Literal['spot']
    beam_width: float | Unset = 15.0
    cutoff_angle: float | Unset = 20.0





    def to_dict(self) -> dict[str, Any]:
        intensity: float | list[float]
        if isinstance(self.intensity, list):
            intensity = self.intensity


        else:
            intensity = self.intensity

        position = self.position



        target = self.target



        type_ = self.type_

        beam_width = self.beam_width

        cutoff_angle = self.cutoff_angle


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "intensity": intensity,
            "position": position,
            "target": target,
            "type": type_,
        })
        if beam_width is not UNSET:
            field_dict["beam_width"] = beam_width
        if cutoff_angle is not UNSET:
            field_dict["cutoff_angle"] = cutoff_angle

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        def _parse_intensity(data: object) -> float | list[float]:
            try:
                if not isinstance(data, list):
                    raise TypeError()
                componentsschemas_rgb_type_1 = cast(list[float], data)

                return componentsschemas_rgb_type_1
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(float | list[float], data)

        intensity = _parse_intensity(d.pop("intensity"))


        position = cast(list[float], d.pop("position"))


        target = cast(list[float], d.pop("target"))


        type_ = cast(Literal['spot'] , d.pop("type"))
        if type_ != 'spot':
            raise ValueError(f"type must match const 'spot', got '{type_}'")

        beam_width = d.pop("beam_width", UNSET)

        cutoff_angle = d.pop("cutoff_angle", UNSET)

        light_desc_type_2 = cls(
            intensity=intensity,
            position=position,
            target=target,
            type_=type_,
            beam_width=beam_width,
            cutoff_angle=cutoff_angle,
        )

        return light_desc_type_2

