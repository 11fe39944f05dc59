from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast






T = TypeVar("T", bound="TransportParams")



@_attrs_define
class TransportParams:
    """ Parameters of a transport bake; defaults filled in before the bake id is computed.

        Attributes:
            azimuths (int | None | Unset): Directions per ring, 4..=256 (default 24: 289 directions; 8 rings of 16 are the
                paper's
                129). Default: 24.
            rings (int | None | Unset): Rings of sampling directions between the pole and the horizon, 1..=64 (default 12).
                Default: 12.
     """

    azimuths: int | None | Unset = 24
    rings: int | None | Unset = 12





    def to_dict(self) -> dict[str, Any]:
        azimuths: int | None | Unset
        if isinstance(self.azimuths, Unset):
            azimuths = UNSET
        else:
            azimuths = self.azimuths

        rings: int | None | Unset
        if isinstance(self.rings, Unset):
            rings = UNSET
        else:
            rings = self.rings


        field_dict: dict[str, Any] = {}

        field_dict.update({
        })
        if azimuths is not UNSET:
            field_dict["azimuths"] = azimuths
        if rings is not UNSET:
            field_dict["rings"] = rings

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        def _parse_azimuths(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        azimuths = _parse_azimuths(d.pop("azimuths", UNSET))


        def _parse_rings(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        rings = _parse_rings(d.pop("rings", UNSET))


        transport_params = cls(
            azimuths=azimuths,
            rings=rings,
        )

        return transport_params

