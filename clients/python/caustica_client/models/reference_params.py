from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast






T = TypeVar("T", bound="ReferenceParams")



@_attrs_define
class ReferenceParams:
    """ Parameters of a reference bake; defaults filled in before the bake id is computed.

        Attributes:
            height (int | None | Unset):
            photons (int | Unset): Photons (light paths) to trace, 1..=1e9. Default: 1000000.
            seed (int | Unset):  Default: 1.
            spp (int | Unset): Camera samples per pixel, 1..=1024. Default: 4.
            width (int | None | Unset): Image size; the scene camera's when absent.
     """

    height: int | None | Unset = UNSET
    photons: int | Unset = 1000000
    seed: int | Unset = 1
    spp: int | Unset = 4
    width: int | None | Unset = UNSET





    def to_dict(self) -> dict[str, Any]:
        height: int | None | Unset
        if isinstance(self.height, Unset):
            height = UNSET
        else:
            height = self.height

        photons = self.photons

        seed = self.seed

        spp = self.spp

        width: int | None | Unset
        if isinstance(self.width, Unset):
            width = UNSET
        else:
            width = self.width


        field_dict: dict[str, Any] = {}

        field_dict.update({
        })
        if height is not UNSET:
            field_dict["height"] = height
        if photons is not UNSET:
            field_dict["photons"] = photons
        if seed is not UNSET:
            field_dict["seed"] = seed
        if spp is not UNSET:
            field_dict["spp"] = spp
        if width is not UNSET:
            field_dict["width"] = width

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        def _parse_height(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        height = _parse_height(d.pop("height", UNSET))


        photons = d.pop("photons", UNSET)

        seed = d.pop("seed", UNSET)

        spp = d.pop("spp", UNSET)

        def _parse_width(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        width = _parse_width(d.pop("width", UNSET))


        reference_params = cls(
            height=height,
            photons=photons,
            seed=seed,
            spp=spp,
            width=width,
        )

        return reference_params

