from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast
from typing import Literal, cast

if TYPE_CHECKING:
  from ..models.readyz_response_200_queued import ReadyzResponse200Queued
  from ..models.readyz_response_200_running import ReadyzResponse200Running





T = TypeVar("T", bound="ReadyzResponse200")



@_attrs_define
class ReadyzResponse200:
    """ 
        Attributes:
            adapter (str):
            queued (ReadyzResponse200Queued): Jobs waiting in this server's queue.
            running (ReadyzResponse200Running): Jobs running in this server.
            status (Literal['ready']):
            storage_warnings (list[str]): What looked wrong with the data directory at start (an empty database file, a
                write-ahead log that is not one, artifacts without records). A 503 appends them to its detail.
     """

    adapter: str
    queued: ReadyzResponse200Queued
    running: ReadyzResponse200Running
    status: Literal['ready']
    storage_warnings: list[str]
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.readyz_response_200_queued import ReadyzResponse200Queued # noqa: PLC0415
        from ..models.readyz_response_200_running import ReadyzResponse200Running # noqa: PLC0415
        adapter = self.adapter

        queued = self.queued.to_dict()

        running = self.running.to_dict()

        status = self.status

        storage_warnings = self.storage_warnings




        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "adapter": adapter,
            "queued": queued,
            "running": running,
            "status": status,
            "storage_warnings": storage_warnings,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.readyz_response_200_queued import ReadyzResponse200Queued # noqa: PLC0415
        from ..models.readyz_response_200_running import ReadyzResponse200Running # noqa: PLC0415
        d = dict(src_dict)
        adapter = d.pop("adapter")

        queued = ReadyzResponse200Queued.from_dict(d.pop("queued"))




        running = ReadyzResponse200Running.from_dict(d.pop("running"))




        status = cast(Literal['ready'] , d.pop("status"))
        if status != 'ready':
            raise ValueError(f"status must match const 'ready', got '{status}'")

        storage_warnings = cast(list[str], d.pop("storage_warnings"))


        readyz_response_200 = cls(
            adapter=adapter,
            queued=queued,
            running=running,
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
