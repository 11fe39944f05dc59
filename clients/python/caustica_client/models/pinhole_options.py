from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..models.strategy import Strategy
from ..types import UNSET, Unset
from typing import cast






T = TypeVar("T", bound="PinholeOptions")



@_attrs_define
class PinholeOptions:
    """ The `pinhole` field of a render request (the CLI's `--samples`, `--sampling`,
    `--no-filter`, `--shadows`, `--transmit`, `--cluster`, `--sun-radius`).

        Attributes:
            cluster (int | None | Unset): Points per cluster, 1..=64 (default 16; 1: every pixel takes every point): a
                receiver
                farther than 6 cluster radii takes a cluster as one pinhole. Default: 16.
            filter_ (bool | None | Unset): Curvature-based anti-aliasing (default true). Default: True.
            samples (int | None | Unset): Sample points over all reflectors, 1..=100000 (default 2000). Default: 2000.
            sampling (None | Strategy | Unset): random, grid, quantized or neighbourhood (default).
            shadows (bool | None | Unset): Occlusion of the reflected light by the scene's objects (default false: 12–19×
                the
                time on lavapipe; needed where a mirror faces the table or itself, see
                docs/methods/pinhole.md). Default: False.
            sun_radius (float | None | Unset): Angular radius in degrees of the disc a directional, point or spot light
                appears as,
                0.01..=10 (default 0.27, the sun's). Default: 0.27.
            transmit (bool | None | Unset): Open glass surfaces (meshes with a boundary: a water surface, a sheet) also
                transmit,
                as one refracting interface (the paper's §5; default false, since a glass solid whose
                mesh has holes would count as open too). Default: False.
     """

    cluster: int | None | Unset = 16
    filter_: bool | None | Unset = True
    samples: int | None | Unset = 2000
    sampling: None | Strategy | Unset = UNSET
    shadows: bool | None | Unset = False
    sun_radius: float | None | Unset = 0.27
    transmit: bool | None | Unset = False





    def to_dict(self) -> dict[str, Any]:
        cluster: int | None | Unset
        if isinstance(self.cluster, Unset):
            cluster = UNSET
        else:
            cluster = self.cluster

        filter_: bool | None | Unset
        if isinstance(self.filter_, Unset):
            filter_ = UNSET
        else:
            filter_ = self.filter_

        samples: int | None | Unset
        if isinstance(self.samples, Unset):
            samples = UNSET
        else:
            samples = self.samples

        sampling: None | str | Unset
        if isinstance(self.sampling, Unset):
            sampling = UNSET
        elif isinstance(self.sampling, Strategy):
            sampling = self.sampling.value
        else:
            sampling = self.sampling

        shadows: bool | None | Unset
        if isinstance(self.shadows, Unset):
            shadows = UNSET
        else:
            shadows = self.shadows

        sun_radius: float | None | Unset
        if isinstance(self.sun_radius, Unset):
            sun_radius = UNSET
        else:
            sun_radius = self.sun_radius

        transmit: bool | None | Unset
        if isinstance(self.transmit, Unset):
            transmit = UNSET
        else:
            transmit = self.transmit


        field_dict: dict[str, Any] = {}

        field_dict.update({
        })
        if cluster is not UNSET:
            field_dict["cluster"] = cluster
        if filter_ is not UNSET:
            field_dict["filter"] = filter_
        if samples is not UNSET:
            field_dict["samples"] = samples
        if sampling is not UNSET:
            field_dict["sampling"] = sampling
        if shadows is not UNSET:
            field_dict["shadows"] = shadows
        if sun_radius is not UNSET:
            field_dict["sun_radius"] = sun_radius
        if transmit is not UNSET:
            field_dict["transmit"] = transmit

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        def _parse_cluster(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        cluster = _parse_cluster(d.pop("cluster", UNSET))


        def _parse_filter_(data: object) -> bool | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(bool | None | Unset, data)

        filter_ = _parse_filter_(d.pop("filter", UNSET))


        def _parse_samples(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        samples = _parse_samples(d.pop("samples", UNSET))


        def _parse_sampling(data: object) -> None | Strategy | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, str):
                    raise TypeError()
                sampling_type_0 = Strategy(data)



                return sampling_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(None | Strategy | Unset, data)

        sampling = _parse_sampling(d.pop("sampling", UNSET))


        def _parse_shadows(data: object) -> bool | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(bool | None | Unset, data)

        shadows = _parse_shadows(d.pop("shadows", UNSET))


        def _parse_sun_radius(data: object) -> float | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(float | None | Unset, data)

        sun_radius = _parse_sun_radius(d.pop("sun_radius", UNSET))


        def _parse_transmit(data: object) -> bool | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(bool | None | Unset, data)

        transmit = _parse_transmit(d.pop("transmit", UNSET))


        pinhole_options = cls(
            cluster=cluster,
            filter_=filter_,
            samples=samples,
            sampling=sampling,
            shadows=shadows,
            sun_radius=sun_radius,
            transmit=transmit,
        )

        return pinhole_options

