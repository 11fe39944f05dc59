from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast






T = TypeVar("T", bound="WaveDesc")



@_attrs_define
class WaveDesc:
    """ One sine wave: h = amplitude · sin(k·(x, z)·dir − ω·t + phase).

        Attributes:
            amplitude (float): Metres, ≥ 0.
            wavelength (float): Metres, > 0.
            heading (float | Unset): Heading in degrees in the horizontal plane: 0 travels along +X, 90 along +Z. Default:
                0.0.
            phase (float | Unset): Radians. Default: 0.0.
            speed (float | None | Unset): Phase speed in m/s (default: deep water, √(gλ/2π)).
     """

    amplitude: float
    wavelength: float
    heading: float | Unset = 0.0
    phase: float | Unset = 0.0
    speed: float | None | Unset = UNSET





    def to_dict(self) -> dict[str, Any]:
        amplitude = self.amplitude

        wavelength = self.wavelength

        heading = self.heading

        phase = self.phase

        speed: float | None | Unset
        if isinstance(self.speed, Unset):
            speed = UNSET
        else:
            speed = self.speed


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "amplitude": amplitude,
            "wavelength": wavelength,
        })
        if heading is not UNSET:
            field_dict["heading"] = heading
        if phase is not UNSET:
            field_dict["phase"] = phase
        if speed is not UNSET:
            field_dict["speed"] = speed

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        amplitude = d.pop("amplitude")

        wavelength = d.pop("wavelength")

        heading = d.pop("heading", UNSET)

        phase = d.pop("phase", UNSET)

        def _parse_speed(data: object) -> float | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(float | None | Unset, data)

        speed = _parse_speed(d.pop("speed", UNSET))


        wave_desc = cls(
            amplitude=amplitude,
            wavelength=wavelength,
            heading=heading,
            phase=phase,
            speed=speed,
        )

        return wave_desc

