from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..models.beams_options_downsample import BeamsOptionsDownsample
from ..models.beams_options_grid import BeamsOptionsGrid
from ..models.bounds import Bounds
from ..types import UNSET, Unset
from typing import cast






T = TypeVar("T", bound="BeamsOptions")



@_attrs_define
class BeamsOptions:
    """ The `beams` field of a render request (the CLI's `--grid`, `--beam-samples`,
    `--no-beam-shadows`, `--one-sided`, `--no-surface`, `--downsample`).

        Attributes:
            bounds (Bounds | None | Unset): The bounding volume a beam is drawn with: hull (default) or touching_planes (the
                paper's prism).
            downsample (BeamsOptionsDownsample | Unset): The volume at 1/downsample of the resolution, upsampled edge-aware:
                1 (default), 2 or 4. Default: BeamsOptionsDownsample.VALUE_1.
            grid (BeamsOptionsGrid | Unset): Grid cells a side: 32, 64, 128 (default) or 256. Default:
                BeamsOptionsGrid.VALUE_128.
            refine (int | None | Unset): Grid cells across a silhouette or a change of path are split refine × refine, 1..=8
                (default 4; 1: the paper's uniform grid). Default: 4.
            samples (int | None | Unset): Samples along a view ray per beam, 1..=16 (default 1, the paper's). Default: 1.
            shadows (bool | None | Unset): Beams end at the first surface their photons meet, so occluders cut them (default
                true; false: the paper's beams, which run through everything). Default: True.
            surface (bool | None | Unset): The beams also light the receivers (surface caustics; default true). Default:
                True.
            two_sided (bool | None | Unset): Refracted photons are traced through their glass object and the beams start
                where they
                leave it (default true; false: the paper's one-sided refraction). Default: True.
     """

    bounds: Bounds | None | Unset = UNSET
    downsample: BeamsOptionsDownsample | Unset = BeamsOptionsDownsample.VALUE_1
    grid: BeamsOptionsGrid | Unset = BeamsOptionsGrid.VALUE_128
    refine: int | None | Unset = 4
    samples: int | None | Unset = 1
    shadows: bool | None | Unset = True
    surface: bool | None | Unset = True
    two_sided: bool | None | Unset = True





    def to_dict(self) -> dict[str, Any]:
        bounds: None | str | Unset
        if isinstance(self.bounds, Unset):
            bounds = UNSET
        elif isinstance(self.bounds, Bounds):
            bounds = self.bounds.value
        else:
            bounds = self.bounds

        downsample: int | Unset = UNSET
        if not isinstance(self.downsample, Unset):
            downsample = self.downsample.value


        grid: int | Unset = UNSET
        if not isinstance(self.grid, Unset):
            grid = self.grid.value


        refine: int | None | Unset
        if isinstance(self.refine, Unset):
            refine = UNSET
        else:
            refine = self.refine

        samples: int | None | Unset
        if isinstance(self.samples, Unset):
            samples = UNSET
        else:
            samples = self.samples

        shadows: bool | None | Unset
        if isinstance(self.shadows, Unset):
            shadows = UNSET
        else:
            shadows = self.shadows

        surface: bool | None | Unset
        if isinstance(self.surface, Unset):
            surface = UNSET
        else:
            surface = self.surface

        two_sided: bool | None | Unset
        if isinstance(self.two_sided, Unset):
            two_sided = UNSET
        else:
            two_sided = self.two_sided


        field_dict: dict[str, Any] = {}

        field_dict.update({
        })
        if bounds is not UNSET:
            field_dict["bounds"] = bounds
        if downsample is not UNSET:
            field_dict["downsample"] = downsample
        if grid is not UNSET:
            field_dict["grid"] = grid
        if refine is not UNSET:
            field_dict["refine"] = refine
        if samples is not UNSET:
            field_dict["samples"] = samples
        if shadows is not UNSET:
            field_dict["shadows"] = shadows
        if surface is not UNSET:
            field_dict["surface"] = surface
        if two_sided is not UNSET:
            field_dict["two_sided"] = two_sided

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        def _parse_bounds(data: object) -> Bounds | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, str):
                    raise TypeError()
                bounds_type_0 = Bounds(data)



                return bounds_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(Bounds | None | Unset, data)

        bounds = _parse_bounds(d.pop("bounds", UNSET))


        _downsample = d.pop("downsample", UNSET)
        downsample: BeamsOptionsDownsample | Unset
        if isinstance(_downsample,  Unset):
            downsample = UNSET
        else:
            downsample = BeamsOptionsDownsample(_downsample)




        _grid = d.pop("grid", UNSET)
        grid: BeamsOptionsGrid | Unset
        if isinstance(_grid,  Unset):
            grid = UNSET
        else:
            grid = BeamsOptionsGrid(_grid)




        def _parse_refine(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        refine = _parse_refine(d.pop("refine", UNSET))


        def _parse_samples(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        samples = _parse_samples(d.pop("samples", UNSET))


        def _parse_shadows(data: object) -> bool | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(bool | None | Unset, data)

        shadows = _parse_shadows(d.pop("shadows", UNSET))


        def _parse_surface(data: object) -> bool | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(bool | None | Unset, data)

        surface = _parse_surface(d.pop("surface", UNSET))


        def _parse_two_sided(data: object) -> bool | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(bool | None | Unset, data)

        two_sided = _parse_two_sided(d.pop("two_sided", UNSET))


        beams_options = cls(
            bounds=bounds,
            downsample=downsample,
            grid=grid,
            refine=refine,
            samples=samples,
            shadows=shadows,
            surface=surface,
            two_sided=two_sided,
        )

        return beams_options

