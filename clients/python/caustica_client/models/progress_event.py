from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..models.job_state import JobState
from ..types import UNSET, Unset
from typing import cast






T = TypeVar("T", bound="ProgressEvent")



@_attrs_define
class ProgressEvent:
    """ The data of a `progress` event (a job's `events` stream).

        Attributes:
            id (str):
            progress (float):
            stage (str):
            state (JobState):
            eta_ms (int | None | Unset):
     """

    id: str
    progress: float
    stage: str
    state: JobState
    eta_ms: int | None | Unset = UNSET
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        id = self.id

        progress = self.progress

        stage = self.stage

        state = self.state.value

        eta_ms: int | None | Unset
        if isinstance(self.eta_ms, Unset):
            eta_ms = UNSET
        else:
            eta_ms = self.eta_ms


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "id": id,
            "progress": progress,
            "stage": stage,
            "state": state,
        })
        if eta_ms is not UNSET:
            field_dict["eta_ms"] = eta_ms

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        id = d.pop("id")

        progress = d.pop("progress")

        stage = d.pop("stage")

        state = JobState(d.pop("state"))




        def _parse_eta_ms(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        eta_ms = _parse_eta_ms(d.pop("eta_ms", UNSET))


        progress_event = cls(
            id=id,
            progress=progress,
            stage=stage,
            state=state,
            eta_ms=eta_ms,
        )


        progress_event.additional_properties = d
        return progress_event

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
