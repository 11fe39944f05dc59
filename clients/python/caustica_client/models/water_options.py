from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..models.mode import Mode
from ..models.variant import Variant
from ..types import UNSET, Unset
from typing import cast






T = TypeVar("T", bound="WaterOptions")



@_attrs_define
class WaterOptions:
    """ The `water` field of a render request (the API's `water_mode` is its `mode`; the CLI's
    `--water-mode`, `--water-variant`, `--water-grid`, `--sun-samples`, `--map-resolution`,
    `--mesh-resolution`, `--sun-map-width`, `--pixel-samples`).

        Attributes:
            grid (int | None | Unset): Physical: sun rays per side of each water rectangle, 16..=2048 (default 512).
                Default: 512.
            map_resolution (int | None | Unset): Texture, shader, shader_texture: texels per side of the light map,
                16..=2048 (default
                1024). Default: 1024.
            mesh_resolution (int | None | Unset): Vertex: quads per side of the receiver grid, 4..=2048 (default 128).
                Default: 128.
            mode (Mode | None | Unset): physical (default) or article.
            pixel_samples (int | None | Unset): Receiver points per pixel side, 1..=8 (default 3: 9 a pixel, fewer where
                width ×
                height × 9 would pass 8 Mi points). Default: 3.
            sun_map_width (float | None | Unset): Article: the sun map's width in degrees, 0.1..=45 (default 4). Default:
                4.0.
            sun_samples (int | None | Unset): Physical: directions over the sun's disc, 1..=64 (default 4). Default: 4.
            variant (None | Unset | Variant): shader (per pixel) or shader_texture (a mipmapped light map) on the GPU;
                pixel,
                texture or vertex on the CPU. Default: shader where the scene has one water shape
                and one directional light and no pixel_samples are given, pixel otherwise.
     """

    grid: int | None | Unset = 512
    map_resolution: int | None | Unset = 1024
    mesh_resolution: int | None | Unset = 128
    mode: Mode | None | Unset = UNSET
    pixel_samples: int | None | Unset = 3
    sun_map_width: float | None | Unset = 4.0
    sun_samples: int | None | Unset = 4
    variant: None | Unset | Variant = UNSET





    def to_dict(self) -> dict[str, Any]:
        grid: int | None | Unset
        if isinstance(self.grid, Unset):
            grid = UNSET
        else:
            grid = self.grid

        map_resolution: int | None | Unset
        if isinstance(self.map_resolution, Unset):
            map_resolution = UNSET
        else:
            map_resolution = self.map_resolution

        mesh_resolution: int | None | Unset
        if isinstance(self.mesh_resolution, Unset):
            mesh_resolution = UNSET
        else:
            mesh_resolution = self.mesh_resolution

        mode: None | str | Unset
        if isinstance(self.mode, Unset):
            mode = UNSET
        elif isinstance(self.mode, Mode):
            mode = self.mode.value
        else:
            mode = self.mode

        pixel_samples: int | None | Unset
        if isinstance(self.pixel_samples, Unset):
            pixel_samples = UNSET
        else:
            pixel_samples = self.pixel_samples

        sun_map_width: float | None | Unset
        if isinstance(self.sun_map_width, Unset):
            sun_map_width = UNSET
        else:
            sun_map_width = self.sun_map_width

        sun_samples: int | None | Unset
        if isinstance(self.sun_samples, Unset):
            sun_samples = UNSET
        else:
            sun_samples = self.sun_samples

        variant: None | str | Unset
        if isinstance(self.variant, Unset):
            variant = UNSET
        elif isinstance(self.variant, Variant):
            variant = self.variant.value
        else:
            variant = self.variant


        field_dict: dict[str, Any] = {}

        field_dict.update({
        })
        if grid is not UNSET:
            field_dict["grid"] = grid
        if map_resolution is not UNSET:
            field_dict["map_resolution"] = map_resolution
        if mesh_resolution is not UNSET:
            field_dict["mesh_resolution"] = mesh_resolution
        if mode is not UNSET:
            field_dict["mode"] = mode
        if pixel_samples is not UNSET:
            field_dict["pixel_samples"] = pixel_samples
        if sun_map_width is not UNSET:
            field_dict["sun_map_width"] = sun_map_width
        if sun_samples is not UNSET:
            field_dict["sun_samples"] = sun_samples
        if variant is not UNSET:
            field_dict["variant"] = variant

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        def _parse_grid(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        grid = _parse_grid(d.pop("grid", UNSET))


        def _parse_map_resolution(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        map_resolution = _parse_map_resolution(d.pop("map_resolution", UNSET))


        def _parse_mesh_resolution(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        mesh_resolution = _parse_mesh_resolution(d.pop("mesh_resolution", UNSET))


        def _parse_mode(data: object) -> Mode | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, str):
                    raise TypeError()
                mode_type_0 = Mode(data)



                return mode_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(Mode | None | Unset, data)

        mode = _parse_mode(d.pop("mode", UNSET))


        def _parse_pixel_samples(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        pixel_samples = _parse_pixel_samples(d.pop("pixel_samples", UNSET))


        def _parse_sun_map_width(data: object) -> float | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(float | None | Unset, data)

        sun_map_width = _parse_sun_map_width(d.pop("sun_map_width", UNSET))


        def _parse_sun_samples(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        sun_samples = _parse_sun_samples(d.pop("sun_samples", UNSET))


        def _parse_variant(data: object) -> None | Unset | Variant:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, str):
                    raise TypeError()
                variant_type_0 = Variant(data)



                return variant_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(None | Unset | Variant, data)

        variant = _parse_variant(d.pop("variant", UNSET))


        water_options = cls(
            grid=grid,
            map_resolution=map_resolution,
            mesh_resolution=mesh_resolution,
            mode=mode,
            pixel_samples=pixel_samples,
            sun_map_width=sun_map_width,
            sun_samples=sun_samples,
            variant=variant,
        )

        return water_options

