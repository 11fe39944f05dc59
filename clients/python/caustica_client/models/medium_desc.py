from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast

if TYPE_CHECKING:
  from ..models.medium_bounds_desc_type_0 import MediumBoundsDescType0
  from ..models.medium_bounds_desc_type_1 import MediumBoundsDescType1
  from ..models.medium_bounds_desc_type_2 import MediumBoundsDescType2





T = TypeVar("T", bound="MediumDesc")



@_attrs_define
class MediumDesc:
    """ A homogeneous participating medium: coefficients per metre and channel, a
    Henyey-Greenstein phase function, and where it is.

        Attributes:
            sigma_s (float | list[float]): A linear RGB triple that may be written as one number (grey) or `[r, g, b]`.
            bounds (MediumBoundsDescType0 | MediumBoundsDescType1 | MediumBoundsDescType2 | Unset): Where a medium is.
            g (float | Unset): Henyey-Greenstein asymmetry, −1 < g < 1: 0 isotropic (default), > 0 forward. Default: 0.0.
            sigma_a (float | list[float] | None | Unset): Absorption coefficient σa, per metre, ≥ 0 (default 0).
     """

    sigma_s: float | list[float]
    bounds: MediumBoundsDescType0 | MediumBoundsDescType1 | MediumBoundsDescType2 | Unset = UNSET
    g: float | Unset = 0.0
    sigma_a: float | list[float] | None | Unset = UNSET





    def to_dict(self) -> dict[str, Any]:
        from ..models.medium_bounds_desc_type_0 import MediumBoundsDescType0 # noqa: PLC0415
        from ..models.medium_bounds_desc_type_1 import MediumBoundsDescType1 # noqa: PLC0415
        from ..models.medium_bounds_desc_type_2 import MediumBoundsDescType2 # noqa: PLC0415
        sigma_s: float | list[float]
        if isinstance(self.sigma_s, list):
            sigma_s = self.sigma_s


        else:
            sigma_s = self.sigma_s

        bounds: dict[str, Any] | Unset
        if isinstance(self.bounds, Unset):
            bounds = UNSET
        elif isinstance(self.bounds, MediumBoundsDescType0):
            bounds = self.bounds.to_dict()
        elif isinstance(self.bounds, MediumBoundsDescType1):
            bounds = self.bounds.to_dict()
        else:
            bounds = self.bounds.to_dict()


        g = self.g

        sigma_a: float | list[float] | None | Unset
        if isinstance(self.sigma_a, Unset):
            sigma_a = UNSET
        elif isinstance(self.sigma_a, list):
            sigma_a = self.sigma_a


        else:
            sigma_a = self.sigma_a


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "sigma_s": sigma_s,
        })
        if bounds is not UNSET:
            field_dict["bounds"] = bounds
        if g is not UNSET:
            field_dict["g"] = g
        if sigma_a is not UNSET:
            field_dict["sigma_a"] = sigma_a

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.medium_bounds_desc_type_0 import MediumBoundsDescType0 # noqa: PLC0415
        from ..models.medium_bounds_desc_type_1 import MediumBoundsDescType1 # noqa: PLC0415
        from ..models.medium_bounds_desc_type_2 import MediumBoundsDescType2 # noqa: PLC0415
        d = dict(src_dict)
        def _parse_sigma_s(data: object) -> float | list[float]:
            try:
                if not isinstance(data, list):
                    raise TypeError()
                componentsschemas_rgb_type_1 = cast(list[float], data)

                return componentsschemas_rgb_type_1
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(float | list[float], data)

        sigma_s = _parse_sigma_s(d.pop("sigma_s"))


        def _parse_bounds(data: object) -> MediumBoundsDescType0 | MediumBoundsDescType1 | MediumBoundsDescType2 | Unset:
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                componentsschemas_medium_bounds_desc_type_0 = MediumBoundsDescType0.from_dict(data)



                return componentsschemas_medium_bounds_desc_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                componentsschemas_medium_bounds_desc_type_1 = MediumBoundsDescType1.from_dict(data)



                return componentsschemas_medium_bounds_desc_type_1
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            if not isinstance(data, dict):
                raise TypeError()
            componentsschemas_medium_bounds_desc_type_2 = MediumBoundsDescType2.from_dict(data)



            return componentsschemas_medium_bounds_desc_type_2

        bounds = _parse_bounds(d.pop("bounds", UNSET))


        g = d.pop("g", UNSET)

        def _parse_sigma_a(data: object) -> float | list[float] | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, list):
                    raise TypeError()
                componentsschemas_rgb_type_1 = cast(list[float], data)

                return componentsschemas_rgb_type_1
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(float | list[float] | None | Unset, data)

        sigma_a = _parse_sigma_a(d.pop("sigma_a", UNSET))


        medium_desc = cls(
            sigma_s=sigma_s,
            bounds=bounds,
            g=g,
            sigma_a=sigma_a,
        )

        return medium_desc

