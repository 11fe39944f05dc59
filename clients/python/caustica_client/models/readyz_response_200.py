from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast
from typing import Literal, cast






T = TypeVar("T", bound="ReadyzResponse200")



@_attrs_define
class ReadyzResponse200:
    """ 
        Attributes:
            adapter (str | Unset):
            status (Literal['ready'] | Unset):
            storage_warnings (list[str] | Unset): What looked wrong with the data directory at start (an empty database
                file, a write-ahead log that is not one, artifacts without records). A 503 appends them to its detail.
     """

    adapter: str | Unset = UNSET
    status: Literal['ready'] | Unset = UNSET
    storage_warnings: list[str] | Unset = UNSET
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        adapter = self.adapter

        status = self.status

        storage_warnings: list[str] | Unset = UNSET
        if not isinstance(self.storage_warnings, Unset):
            storage_warnings = self.storage_warnings




        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
        })
        if adapter is not UNSET:
            field_dict["adapter"] = adapter
        if status is not UNSET:
            field_dict["status"] = status
        if storage_warnings is not UNSET:
            field_dict["storage_warnings"] = storage_warnings

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        adapter = d.pop("adapter", UNSET)

        status = cast(Literal['ready'] | Unset , d.pop("status", UNSET))
        if status != 'ready'and not isinstance(status, Unset):
            raise ValueError(f"status must match const 'ready', got '{status}'")

        storage_warnings = cast(list[str], d.pop("storage_warnings", UNSET))


        readyz_response_200 = cls(
            adapter=adapter,
            status=status,
            storage_warnings=storage_warnings,
        )


        readyz_response_200.additional_properties = d
        return readyz_response_200

    @property
    def additional_keys(self) -> list[str]:
        return list(self.additional_properties.keys())

    def __getitem__(self, key: str) -> Any:
        return self.additional_properties[key]

    def __setitem__(self, key: str, value: Any) -> None:
        self.additional_properties[key] = value

    def __delitem__(self, key: str) -> None:
        del self.additional_properties[key]

    def __contains__(self, key: str) -> bool:
        return key in self.additional_properties
