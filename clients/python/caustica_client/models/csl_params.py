from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..models.csl_params_preset import CslParamsPreset
from ..types import UNSET, Unset
from typing import cast






T = TypeVar("T", bound="CslParams")



@_attrs_define
class CslParams:
    """ Parameters of a CSL bake (the `params` of a `csl` bake, the `csl` field of a `csl` render);
    defaults filled in before the bake id is computed.

        Attributes:
            dynamic (bool | Unset): Dynamic lighting (Liu et al. 2008 §4): a set per direction of a subdivided icosahedron,
                matched into triples; serves every directional light. Omitted when false.
            grid (int | None | Unset): Rays per side of the ray grid over the silhouette, 16..=4096 (the paper: 1280).
            match_threshold (float | None | Unset): Dynamic: the largest axis distance of a match, in bounding-sphere radii,
                (0, 10]
                (default 0.5). Omitted when not given. Default: 0.5.
            preset (CslParamsPreset | Unset): `paper` (the paper's settings) or `fast` (coarser cells and images, for
                previews). Default: CslParamsPreset.PAPER.
            steps (int | None | Unset): Dynamic: tracking steps along an icosahedron edge, 1..=100 (default 20). Default:
                20.
            subdivisions (int | None | Unset): Dynamic: icosahedron subdivisions, 0..=3 (default 2: 162 directions).
                Default: 2.
            track_grid (int | None | Unset): Dynamic: rays per side of the grid traced at each tracking step, 16..=1024
                (default 96). Default: 96.
     """

    dynamic: bool | Unset = UNSET
    grid: int | None | Unset = UNSET
    match_threshold: float | None | Unset = 0.5
    preset: CslParamsPreset | Unset = CslParamsPreset.PAPER
    steps: int | None | Unset = 20
    subdivisions: int | None | Unset = 2
    track_grid: int | None | Unset = 96





    def to_dict(self) -> dict[str, Any]:
        dynamic = self.dynamic

        grid: int | None | Unset
        if isinstance(self.grid, Unset):
            grid = UNSET
        else:
            grid = self.grid

        match_threshold: float | None | Unset
        if isinstance(self.match_threshold, Unset):
            match_threshold = UNSET
        else:
            match_threshold = self.match_threshold

        preset: str | Unset = UNSET
        if not isinstance(self.preset, Unset):
            preset = self.preset.value


        steps: int | None | Unset
        if isinstance(self.steps, Unset):
            steps = UNSET
        else:
            steps = self.steps

        subdivisions: int | None | Unset
        if isinstance(self.subdivisions, Unset):
            subdivisions = UNSET
        else:
            subdivisions = self.subdivisions

        track_grid: int | None | Unset
        if isinstance(self.track_grid, Unset):
            track_grid = UNSET
        else:
            track_grid = self.track_grid


        field_dict: dict[str, Any] = {}

        field_dict.update({
        })
        if dynamic is not UNSET:
            field_dict["dynamic"] = dynamic
        if grid is not UNSET:
            field_dict["grid"] = grid
        if match_threshold is not UNSET:
            field_dict["match_threshold"] = match_threshold
        if preset is not UNSET:
            field_dict["preset"] = preset
        if steps is not UNSET:
            field_dict["steps"] = steps
        if subdivisions is not UNSET:
            field_dict["subdivisions"] = subdivisions
        if track_grid is not UNSET:
            field_dict["track_grid"] = track_grid

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        dynamic = d.pop("dynamic", UNSET)

        def _parse_grid(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        grid = _parse_grid(d.pop("grid", UNSET))


        def _parse_match_threshold(data: object) -> float | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(float | None | Unset, data)

        match_threshold = _parse_match_threshold(d.pop("match_threshold", UNSET))


        _preset = d.pop("preset", UNSET)
        preset: CslParamsPreset | Unset
        if isinstance(_preset,  Unset):
            preset = UNSET
        else:
            preset = CslParamsPreset(_preset)




        def _parse_steps(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        steps = _parse_steps(d.pop("steps", UNSET))


        def _parse_subdivisions(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        subdivisions = _parse_subdivisions(d.pop("subdivisions", UNSET))


        def _parse_track_grid(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        track_grid = _parse_track_grid(d.pop("track_grid", UNSET))


        csl_params = cls(
            dynamic=dynamic,
            grid=grid,
            match_threshold=match_threshold,
            preset=preset,
            steps=steps,
            subdivisions=subdivisions,
            track_grid=track_grid,
        )

        return csl_params

