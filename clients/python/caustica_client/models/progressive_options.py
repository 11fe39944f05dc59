from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast






T = TypeVar("T", bound="ProgressiveOptions")



@_attrs_define
class ProgressiveOptions:
    """ The `progressive` field of a render request (the CLI's `--photons-per-frame`,
    `--time-budget`, `--error-target` and `--footprint`).

        Attributes:
            error_target (float | None | Unset): Return the frame once the estimated noise (relative L1 per pixel) is at
                most this,
                (0, 1).
            footprint (float | None | Unset): The first frame's kernel half-size in spacings of neighbouring photons,
                0.5..=8
                (default 3). Default: 3.0.
            photons_per_frame (int | None | Unset): Photons traced per frame, 1024..=4194240 (default 524288). Default:
                524288.
            time_budget_ms (int | None | Unset): Return the frame after this many milliseconds of photon frames, 1..=600000.
     """

    error_target: float | None | Unset = UNSET
    footprint: float | None | Unset = 3.0
    photons_per_frame: int | None | Unset = 524288
    time_budget_ms: int | None | Unset = UNSET





    def to_dict(self) -> dict[str, Any]:
        error_target: float | None | Unset
        if isinstance(self.error_target, Unset):
            error_target = UNSET
        else:
            error_target = self.error_target

        footprint: float | None | Unset
        if isinstance(self.footprint, Unset):
            footprint = UNSET
        else:
            footprint = self.footprint

        photons_per_frame: int | None | Unset
        if isinstance(self.photons_per_frame, Unset):
            photons_per_frame = UNSET
        else:
            photons_per_frame = self.photons_per_frame

        time_budget_ms: int | None | Unset
        if isinstance(self.time_budget_ms, Unset):
            time_budget_ms = UNSET
        else:
            time_budget_ms = self.time_budget_ms


        field_dict: dict[str, Any] = {}

        field_dict.update({
        })
        if error_target is not UNSET:
            field_dict["error_target"] = error_target
        if footprint is not UNSET:
            field_dict["footprint"] = footprint
        if photons_per_frame is not UNSET:
            field_dict["photons_per_frame"] = photons_per_frame
        if time_budget_ms is not UNSET:
            field_dict["time_budget_ms"] = time_budget_ms

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        def _parse_error_target(data: object) -> float | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(float | None | Unset, data)

        error_target = _parse_error_target(d.pop("error_target", UNSET))


        def _parse_footprint(data: object) -> float | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(float | None | Unset, data)

        footprint = _parse_footprint(d.pop("footprint", UNSET))


        def _parse_photons_per_frame(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        photons_per_frame = _parse_photons_per_frame(d.pop("photons_per_frame", UNSET))


        def _parse_time_budget_ms(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        time_budget_ms = _parse_time_budget_ms(d.pop("time_budget_ms", UNSET))


        progressive_options = cls(
            error_target=error_target,
            footprint=footprint,
            photons_per_frame=photons_per_frame,
            time_budget_ms=time_budget_ms,
        )

        return progressive_options

