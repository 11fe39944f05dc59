from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..models.method import Method






T = TypeVar("T", bound="MethodFit")



@_attrs_define
class MethodFit:
    """ Whether a method can render a scene, and why or why not: listed with every stored scene
    (its `methods`) so a client can offer the methods that fit.

        Attributes:
            bake (bool): Whether it bakes first (a render without a bake made beforehand makes it then).
            fits (bool): Whether a render of the scene with this method and its default parameters is accepted.
            gpu (bool): Whether its frames need a GPU adapter (a server without one answers 503 to them).
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
            why (str): For `auto`, the method it picks and why; for a method that fits, what it gives this
                scene; otherwise the field at fault and why (the render's 422 message).
     """

    bake: bool
    fits: bool
    gpu: bool
    method: Method
    why: str
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        bake = self.bake

        fits = self.fits

        gpu = self.gpu

        method = self.method.value

        why = self.why


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "bake": bake,
            "fits": fits,
            "gpu": gpu,
            "method": method,
            "why": why,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        bake = d.pop("bake")

        fits = d.pop("fits")

        gpu = d.pop("gpu")

        method = Method(d.pop("method"))




        why = d.pop("why")

        method_fit = cls(
            bake=bake,
            fits=fits,
            gpu=gpu,
            method=method,
            why=why,
        )


        method_fit.additional_properties = d
        return method_fit

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
