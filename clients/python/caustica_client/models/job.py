from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..models.job_kind import JobKind
from ..models.job_state import JobState
from ..models.method import Method
from ..types import UNSET, Unset
from typing import cast

if TYPE_CHECKING:
  from ..models.job_info import JobInfo
  from ..models.job_params import JobParams
  from ..models.timing import Timing





T = TypeVar("T", bound="Job")



@_attrs_define
class Job:
    """ A job as the API shows it.

        Attributes:
            artifact (None | str): Where the result is, once succeeded.
            created_at (int): Milliseconds since the Unix epoch.
            error (None | str): Why it failed or was canceled; null otherwise.
            finished_at (int | None):
            id (str):
            info (JobInfo): What the job learned: adapter, statistics, image size, notes...; for a failed job
                `error_code`, one of canceled, timeout, interrupted, invalid_input, invalid_params,
                no_gpu, render, encode, panic, store, worker_lost.
            kind (JobKind): The two kinds of job.

                - `bake`: Precomputation whose artifact is kept (`POST /v1/bakes`).
                - `render`: A frame (`POST /v1/renders`).
            method (Method): A method as a request names it.

                - `auto`: Picks one of the others from the scene (the rule is in `methods::auto`).
                - `direct`: GPU direct lighting with shadow maps; glass and mirrors drawn from the environment (no caustics).
                - `reference`: CPU ground truth: photon tracing + camera paths.
                - `csl`: Caustic spot lights (Liu et al. 2008): CPU bake, caustics evaluated per pixel on the GPU; directional
                lights.
                - `transport`: Light transport tables (Iwasaki et al. 2005): CPU bake, illumination volumes drawn on the GPU;
                directional, point, spot and line lights. Needs a float-blendable adapter.
                - `pinhole`: Pinhole caustics (Wand and Straßer 2003): no bake, points on the reflectors project the environment
                and the lights onto the receivers every frame.
                - `water`: Underwater caustics (Sánchez-Crespo 2003): sunlight refracted by a procedural water surface onto what
                lies below it; the article's mode or a physical one.
                - `beams`: Volumetric caustics with projected light beams (Liktor and Dachsbacher 2010): beams from a grid
                projected onto the glass and mirrors, intersected per pixel in the scene's medium; they also give the surface
                caustics.
                - `photons`: Progressive GPU photon tracing with photon differentials: no bake, any glass or mirror object,
                every light type; converges to the reference's caustics frame by frame.
            params (JobParams): The method's parameters with their defaults filled in (a bake's `params`; a render's
                request fields other than scene, method and wait).
            progress (float):
            scene_id (str):
            stage (str): What it is doing now (a method's stage name; `queued`, `done` and the like otherwise).
            started_at (int | None):
            state (JobState):
            timings (list[Timing]): Stage → milliseconds, in order.
            eta_ms (int | None | Unset): While running: milliseconds it may still take, from its progress so far (its time
                running × (1 − progress) / progress); absent before 1 % of progress and otherwise.
            object_ (None | str | Unset):
     """

    artifact: None | str
    created_at: int
    error: None | str
    finished_at: int | None
    id: str
    info: JobInfo
    kind: JobKind
    method: Method
    params: JobParams
    progress: float
    scene_id: str
    stage: str
    started_at: int | None
    state: JobState
    timings: list[Timing]
    eta_ms: int | None | Unset = UNSET
    object_: None | str | Unset = UNSET
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.job_info import JobInfo # noqa: PLC0415
        from ..models.job_params import JobParams # noqa: PLC0415
        from ..models.timing import Timing # noqa: PLC0415
        artifact: None | str
        artifact = self.artifact

        created_at = self.created_at

        error: None | str
        error = self.error

        finished_at: int | None
        finished_at = self.finished_at

        id = self.id

        info = self.info.to_dict()

        kind = self.kind.value

        method = self.method.value

        params = self.params.to_dict()

        progress = self.progress

        scene_id = self.scene_id

        stage = self.stage

        started_at: int | None
        started_at = self.started_at

        state = self.state.value

        timings = []
        for timings_item_data in self.timings:
            timings_item = timings_item_data.to_dict()
            timings.append(timings_item)



        eta_ms: int | None | Unset
        if isinstance(self.eta_ms, Unset):
            eta_ms = UNSET
        else:
            eta_ms = self.eta_ms

        object_: None | str | Unset
        if isinstance(self.object_, Unset):
            object_ = UNSET
        else:
            object_ = self.object_


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "artifact": artifact,
            "created_at": created_at,
            "error": error,
            "finished_at": finished_at,
            "id": id,
            "info": info,
            "kind": kind,
            "method": method,
            "params": params,
            "progress": progress,
            "scene_id": scene_id,
            "stage": stage,
            "started_at": started_at,
            "state": state,
            "timings": timings,
        })
        if eta_ms is not UNSET:
            field_dict["eta_ms"] = eta_ms
        if object_ is not UNSET:
            field_dict["object"] = object_

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.job_info import JobInfo # noqa: PLC0415
        from ..models.job_params import JobParams # noqa: PLC0415
        from ..models.timing import Timing # noqa: PLC0415
        d = dict(src_dict)
        def _parse_artifact(data: object) -> None | str:
            if data is None:
                return data
            return cast(None | str, data)

        artifact = _parse_artifact(d.pop("artifact"))


        created_at = d.pop("created_at")

        def _parse_error(data: object) -> None | str:
            if data is None:
                return data
            return cast(None | str, data)

        error = _parse_error(d.pop("error"))


        def _parse_finished_at(data: object) -> int | None:
            if data is None:
                return data
            return cast(int | None, data)

        finished_at = _parse_finished_at(d.pop("finished_at"))


        id = d.pop("id")

        info = JobInfo.from_dict(d.pop("info"))




        kind = JobKind(d.pop("kind"))




        method = Method(d.pop("method"))




        params = JobParams.from_dict(d.pop("params"))




        progress = d.pop("progress")

        scene_id = d.pop("scene_id")

        stage = d.pop("stage")

        def _parse_started_at(data: object) -> int | None:
            if data is None:
                return data
            return cast(int | None, data)

        started_at = _parse_started_at(d.pop("started_at"))


        state = JobState(d.pop("state"))




        timings = []
        _timings = d.pop("timings")
        for timings_item_data in (_timings):
            timings_item = Timing.from_dict(timings_item_data)



            timings.append(timings_item)


        def _parse_eta_ms(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        eta_ms = _parse_eta_ms(d.pop("eta_ms", UNSET))


        def _parse_object_(data: object) -> None | str | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(None | str | Unset, data)

        object_ = _parse_object_(d.pop("object", UNSET))


        job = cls(
            artifact=artifact,
            created_at=created_at,
            error=error,
            finished_at=finished_at,
            id=id,
            info=info,
            kind=kind,
            method=method,
            params=params,
            progress=progress,
            scene_id=scene_id,
            stage=stage,
            started_at=started_at,
            state=state,
            timings=timings,
            eta_ms=eta_ms,
            object_=object_,
        )


        job.additional_properties = d
        return job

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
