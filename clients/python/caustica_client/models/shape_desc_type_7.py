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
  from ..models.waves_desc_type_0 import WavesDescType0
  from ..models.waves_desc_type_1 import WavesDescType1





T = TypeVar("T", bound="ShapeDescType7")



@_attrs_define
class ShapeDescType7:
    """ A procedural water surface over a rectangle (local y = 0 is the mean surface), the water
    body below it and optionally a floor. The object's transform may only translate it.

        Attributes:
            size (list[float]): [x extent, z extent] of the rectangle, metres.
            type_ (Literal['water']):
            absorption (float | list[float] | Unset): A linear RGB triple that may be written as one number (grey) or `[r,
                g, b]`.
            depth (float | Unset): Metres from the mean surface down to the bottom of the body, > 0 (default 1). Default:
                1.0.
            floor (float | list[float] | None | Unset): Albedo of a diffuse floor at `depth` over the whole rectangle (an
                object named
                `<name>-floor`); none when absent.
            ior (float | Unset): Index of refraction of the water (default 1.33). Default: 1.3300000429153442.
            resolution (int | Unset): Quads per side of the surface's tessellation, 2..=1024 (default 256): what the
                reference and the direct pass see (normals come from the analytic gradient). Default: 256.
            time (float | Unset): Seconds (default 0). Default: 0.0.
            waves (Unset | WavesDescType0 | WavesDescType1): The wave preset of a water surface.
     """

    size: list[float]
    type_: Literal['water']
    absorption: float | list[float] | Unset = UNSET
    depth: float | Unset = 1.0
    floor: float | list[float] | None | Unset = UNSET
    ior: float | Unset = 1.3300000429153442
    resolution: int | Unset = 256
    time: float | Unset = 0.0
    waves: Unset | WavesDescType0 | WavesDescType1 = UNSET





    def to_dict(self) -> dict[str, Any]:
        from ..models.waves_desc_type_0 import WavesDescType0 # noqa: PLC0415
        from ..models.waves_desc_type_1 import WavesDescType1 # noqa: PLC0415
        size = self.size



        type_ = self.type_

        absorption: float | list[float] | Unset
        if isinstance(self.absorption, Unset):
            absorption = UNSET
        elif isinstance(self.absorption, list):
            absorption = self.absorption


        else:
            absorption = self.absorption

        depth = self.depth

        floor: float | list[float] | None | Unset
        if isinstance(self.floor, Unset):
            floor = UNSET
        elif isinstance(self.floor, list):
            floor = self.floor


        else:
            floor = self.floor

        ior = self.ior

        resolution = self.resolution

        time = self.time

        waves: dict[str, Any] | Unset
        if isinstance(self.waves, Unset):
            waves = UNSET
        elif isinstance(self.waves, WavesDescType0):
            waves = self.waves.to_dict()
        else:
            waves = self.waves.to_dict()



        field_dict: dict[str, Any] = {}

        field_dict.update({
            "size": size,
            "type": type_,
        })
        if absorption is not UNSET:
            field_dict["absorption"] = absorption
        if depth is not UNSET:
            field_dict["depth"] = depth
        if floor is not UNSET:
            field_dict["floor"] = floor
        if ior is not UNSET:
            field_dict["ior"] = ior
        if resolution is not UNSET:
            field_dict["resolution"] = resolution
        if time is not UNSET:
            field_dict["time"] = time
        if waves is not UNSET:
            field_dict["waves"] = waves

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.waves_desc_type_0 import WavesDescType0 # noqa: PLC0415
        from ..models.waves_desc_type_1 import WavesDescType1 # noqa: PLC0415
        d = dict(src_dict)
        size = cast(list[float], d.pop("size"))


        type_ = cast(Literal['water'] , d.pop("type"))
        if type_ != 'water':
            raise ValueError(f"type must match const 'water', got '{type_}'")

        def _parse_absorption(data: object) -> float | list[float] | Unset:
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, list):
                    raise TypeError()
                componentsschemas_rgb_type_1 = cast(list[float], data)

                return componentsschemas_rgb_type_1
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(float | list[float] | Unset, data)

        absorption = _parse_absorption(d.pop("absorption", UNSET))


        depth = d.pop("depth", UNSET)

        def _parse_floor(data: object) -> float | list[float] | None | Unset:
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

        floor = _parse_floor(d.pop("floor", UNSET))


        ior = d.pop("ior", UNSET)

        resolution = d.pop("resolution", UNSET)

        time = d.pop("time", UNSET)

        def _parse_waves(data: object) -> Unset | WavesDescType0 | WavesDescType1:
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                componentsschemas_waves_desc_type_0 = WavesDescType0.from_dict(data)



                return componentsschemas_waves_desc_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            if not isinstance(data, dict):
                raise TypeError()
            componentsschemas_waves_desc_type_1 = WavesDescType1.from_dict(data)



            return componentsschemas_waves_desc_type_1

        waves = _parse_waves(d.pop("waves", UNSET))


        shape_desc_type_7 = cls(
            size=size,
            type_=type_,
            absorption=absorption,
            depth=depth,
            floor=floor,
            ior=ior,
            resolution=resolution,
            time=time,
            waves=waves,
        )

        return shape_desc_type_7

