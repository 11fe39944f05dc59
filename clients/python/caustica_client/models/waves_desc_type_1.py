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
  from ..models.wave_desc import WaveDesc





T = TypeVar("T", bound="WavesDescType1")



@_attrs_define
class WavesDescType1:
    """ Directional sine waves, lengths in metres (default: a five-wave swell, steepness
    a·k ≈ 0.04 each).

        Attributes:
            preset (Literal['physical']):
            waves (list[WaveDesc] | Unset):
     """

    preset: Literal['physical']
    waves: list[WaveDesc] | Unset = UNSET





    def to_dict(self) -> dict[str, Any]:
        from ..models.wave_desc import WaveDesc # noqa: PLC0415
        preset = self.preset

        waves: list[dict[str, Any]] | Unset = UNSET
        if not isinstance(self.waves, Unset):
            waves = []
            for waves_item_data in self.waves:
                waves_item = waves_item_data.to_dict()
                waves.append(waves_item)




        field_dict: dict[str, Any] = {}

        field_dict.update({
            "preset": preset,
        })
        if waves is not UNSET:
            field_dict["waves"] = waves

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.wave_desc import WaveDesc # noqa: PLC0415
        d = dict(src_dict)
        preset = cast(Literal['physical'] , d.pop("preset"))
        if preset != 'physical':
            raise ValueError(f"preset must match const 'physical', got '{preset}'")

        _waves = d.pop("waves", UNSET)
        waves: list[WaveDesc] | Unset = UNSET
        if _waves is not UNSET:
            waves = []
            for waves_item_data in _waves:
                waves_item = WaveDesc.from_dict(waves_item_data)



                waves.append(waves_item)


        waves_desc_type_1 = cls(
            preset=preset,
            waves=waves,
        )

        return waves_desc_type_1

