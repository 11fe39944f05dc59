from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import Literal, cast






T = TypeVar("T", bound="WavesDescType0")



@_attrs_define
class WavesDescType0:
    """ The article's wave function (defaults: its constants OCTAVES 5, VTXSIZE 0.01,
    WAVESIZE 10, FACTOR 1, SPEED 2).

        Attributes:
            preset (Literal['article']):
            amplitude (float | Unset): VTXSIZE: amplitude, in units of the rectangle's x side. Default:
                0.009999999776482582.
            factor (float | Unset): FACTOR: the first octave's weight; each next octave halves it and doubles its
                frequency. Default: 1.0.
            frequency (float | Unset): WAVESIZE: frequency. Default: 10.0.
            octaves (int | Unset):  Default: 5.
            speed (float | Unset): SPEED: phase advance per second, radians. Default: 2.0.
     """

    preset: Literal['article']
    amplitude: float | Unset = 0.009999999776482582
    factor: float | Unset = 1.0
    frequency: float | Unset = 10.0
    octaves: int | Unset = 5
    speed: float | Unset = 2.0





    def to_dict(self) -> dict[str, Any]:
        preset = self.preset

        amplitude = self.amplitude

        factor = self.factor

        frequency = self.frequency

        octaves = self.octaves

        speed = self.speed


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "preset": preset,
        })
        if amplitude is not UNSET:
            field_dict["amplitude"] = amplitude
        if factor is not UNSET:
            field_dict["factor"] = factor
        if frequency is not UNSET:
            field_dict["frequency"] = frequency
        if octaves is not UNSET:
            field_dict["octaves"] = octaves
        if speed is not UNSET:
            field_dict["speed"] = speed

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        preset = cast(Literal['article'] , d.pop("preset"))
        if preset != 'article':
            raise ValueError(f"preset must match const 'article', got '{preset}'")

        amplitude = d.pop("amplitude", UNSET)

        factor = d.pop("factor", UNSET)

        frequency = d.pop("frequency", UNSET)

        octaves = d.pop("octaves", UNSET)

        speed = d.pop("speed", UNSET)

        waves_desc_type_0 = cls(
            preset=preset,
            amplitude=amplitude,
            factor=factor,
            frequency=frequency,
            octaves=octaves,
            speed=speed,
        )

        return waves_desc_type_0

