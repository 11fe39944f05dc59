from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..models.component import Component
from ..models.format_ import Format
from ..models.method import Method
from ..models.mode import Mode
from ..models.tone_map import ToneMap
from ..types import UNSET, Unset
from typing import cast

if TYPE_CHECKING:
  from ..models.beams_options import BeamsOptions
  from ..models.camera_desc import CameraDesc
  from ..models.csl_params import CslParams
  from ..models.light_desc_type_0 import LightDescType0
  from ..models.light_desc_type_1 import LightDescType1
  from ..models.light_desc_type_2 import LightDescType2
  from ..models.light_desc_type_3 import LightDescType3
  from ..models.light_desc_type_4 import LightDescType4
  from ..models.pinhole_options import PinholeOptions
  from ..models.progressive_options import ProgressiveOptions
  from ..models.scene import Scene
  from ..models.water_options import WaterOptions





T = TypeVar("T", bound="RenderRequest")



@_attrs_define
class RenderRequest:
    """ The body of `POST /v1/renders`: the scene, the method, and the render's parameters (each
    method's own options in the field named after it: `csl`, `pinhole`, `water`, `beams`,
    `progressive`; a method's options given to another method are refused with 422).

        Attributes:
            scene (Scene | str): The scene of a request: a scene object, or the id of a stored scene.
            beams (BeamsOptions | None | Unset): beams only (Liktor and Dachsbacher 2010, no bake); see
                docs/methods/beams.md.
            camera (CameraDesc | None | Unset): Replaces the scene's camera.
            check (bool | None | Unset): Runs the self-check, a short reference of the caustics compared with the frame on
                the
                receivers (its figures in `info.statistics.check`; about a second of CPU), or not.
                Default: on for csl and transport, and for `auto` where its rule is unsure; off
                otherwise.
            component (Component | Unset): One component of a frame (Jensen's path notation: L light, S specular, D diffuse,
                E eye).

                - `total`: The sum of the others.
                - `direct`: Light → receiver → camera (L D E); specular objects cast shadows.
                - `caustics`: Light through glass or off mirrors onto the first diffuse receiver (L S+ D E).
                - `specular`: What the camera sees in glass and mirrors (… S+ E).
                - `indirect`: Every other path of two or more bounces: diffuse interreflection, and light a diffuse surface
                sends through glass (L D S+ D E).
                - `volume`: Light scattered towards the camera by a participating medium (L … V E), other than
                `volume_caustics`.
                - `volume_caustics`: Light that went through glass or off mirrors and then scattered once in the medium towards
                the camera (L S+ V E): the volumetric caustic.
            csl (CslParams | None | Unset): csl only: the bake's parameters, as for `POST /v1/bakes` (default: the paper's).
                With
                `dynamic: true` the render uses the static bake made for exactly the scene's light with
                the same preset and grid when the data directory keeps one (see `refine`), else the
                dynamic bake of these parameters (found in the data directory, e.g. made by a bake job,
                or baked now) and the set interpolated from it for the light's direction.
            exposure (float | Unset): PNG exposure in stops. Default: 0.0.
            format_ (Format | Unset):
            fps (float | None | Unset): A sequence's frames per second, 0.1..=60 (default 24). Default: 24.0.
            frames (int | None | Unset): Scenes with water: a sequence of this many frames, 1..=240, answered as an animated
                PNG
                (format png only).
            ground (bool | Unset): Adds a diffuse ground plane under the scene's objects (`"ground": true` in a scene does
                the same): for a glass or mirror object uploaded alone, whose shadow and caustic
                otherwise fall on nothing. Default: False.
            height (int | None | Unset):
            layers (bool | Unset): EXR only: every component as a layer (the chosen one first). Default: False.
            lights (list[LightDescType0 | LightDescType1 | LightDescType2 | LightDescType3 | LightDescType4] | None |
                Unset): Replaces the scene's lights (lights inside glTF files stay).
            method (Method | Unset): A method as a request names it.

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
            photons (int | None | Unset): reference and photons: light paths to trace in all (defaults 4,000,000 and
                1,048,576).
            pinhole (None | PinholeOptions | Unset): pinhole only (Wand and Straßer 2003, no bake): sample points on the
                mirrors and glass
                project the environment and the lights onto the receivers every frame.
            progressive (None | ProgressiveOptions | Unset): photons only (progressive photon tracing, no bake); see
                docs/methods/photons.md.
            refine (bool | None | Unset): csl with `dynamic` only: when the frame was served by sets interpolated from the
                dynamic bake, queue the static bake of each object for exactly this light (the same
                preset and grid; cached by content hash), so that the next frame at this light direction
                is served by it (default true). The render's `info.refine` names the bakes.
            seed (int | None | Unset): reference and photons: the random sequence's seed.
            spp (int | None | Unset): reference only: camera samples per pixel.
            time (float | None | Unset): Scenes with water: the waves' time in seconds (any method); the first frame's time
                of a
                sequence.
            tone_map (None | ToneMap | Unset): PNG tone map (clamp by default, as the CLI).
            volume_bounces (int | None | Unset): reference only: scatterings in the scene's medium a light path may have (1:
                single
                scattering), 1..=1000 (default: unlimited).
            wait (bool | Unset): false: answer 202 with the job at once; true: wait for the image up to the server's
                wait (then 202). Default: True.
            water (None | Unset | WaterOptions): water only (Sánchez-Crespo 2003, no bake); see docs/methods/water.md.
            water_mode (Mode | None | Unset): water only: `physical` (the default: a refracted grid of sun rays, irradiance
                from the
                area ratio, converges to the reference) or `article` (the article's sun-map lookup).
            width (int | None | Unset): Image size; the camera's when absent.
     """

    scene: Scene | str
    beams: BeamsOptions | None | Unset = UNSET
    camera: CameraDesc | None | Unset = UNSET
    check: bool | None | Unset = UNSET
    component: Component | Unset = UNSET
    csl: CslParams | None | Unset = UNSET
    exposure: float | Unset = 0.0
    format_: Format | Unset = UNSET
    fps: float | None | Unset = 24.0
    frames: int | None | Unset = UNSET
    ground: bool | Unset = False
    height: int | None | Unset = UNSET
    layers: bool | Unset = False
    lights: list[LightDescType0 | LightDescType1 | LightDescType2 | LightDescType3 | LightDescType4] | None | Unset = UNSET
    method: Method | Unset = UNSET
    photons: int | None | Unset = UNSET
    pinhole: None | PinholeOptions | Unset = UNSET
    progressive: None | ProgressiveOptions | Unset = UNSET
    refine: bool | None | Unset = UNSET
    seed: int | None | Unset = UNSET
    spp: int | None | Unset = UNSET
    time: float | None | Unset = UNSET
    tone_map: None | ToneMap | Unset = UNSET
    volume_bounces: int | None | Unset = UNSET
    wait: bool | Unset = True
    water: None | Unset | WaterOptions = UNSET
    water_mode: Mode | None | Unset = UNSET
    width: int | None | Unset = UNSET





    def to_dict(self) -> dict[str, Any]:
        from ..models.beams_options import BeamsOptions # noqa: PLC0415
        from ..models.camera_desc import CameraDesc # noqa: PLC0415
        from ..models.csl_params import CslParams # noqa: PLC0415
        from ..models.light_desc_type_0 import LightDescType0 # noqa: PLC0415
        from ..models.light_desc_type_1 import LightDescType1 # noqa: PLC0415
        from ..models.light_desc_type_2 import LightDescType2 # noqa: PLC0415
        from ..models.light_desc_type_3 import LightDescType3 # noqa: PLC0415
        from ..models.light_desc_type_4 import LightDescType4 # noqa: PLC0415
        from ..models.pinhole_options import PinholeOptions # noqa: PLC0415
        from ..models.progressive_options import ProgressiveOptions # noqa: PLC0415
        from ..models.scene import Scene # noqa: PLC0415
        from ..models.water_options import WaterOptions # noqa: PLC0415
        scene: dict[str, Any] | str
        if isinstance(self.scene, Scene):
            scene = self.scene.to_dict()
        else:
            scene = self.scene

        beams: dict[str, Any] | None | Unset
        if isinstance(self.beams, Unset):
            beams = UNSET
        elif isinstance(self.beams, BeamsOptions):
            beams = self.beams.to_dict()
        else:
            beams = self.beams

        camera: dict[str, Any] | None | Unset
        if isinstance(self.camera, Unset):
            camera = UNSET
        elif isinstance(self.camera, CameraDesc):
            camera = self.camera.to_dict()
        else:
            camera = self.camera

        check: bool | None | Unset
        if isinstance(self.check, Unset):
            check = UNSET
        else:
            check = self.check

        component: str | Unset = UNSET
        if not isinstance(self.component, Unset):
            component = self.component.value


        csl: dict[str, Any] | None | Unset
        if isinstance(self.csl, Unset):
            csl = UNSET
        elif isinstance(self.csl, CslParams):
            csl = self.csl.to_dict()
        else:
            csl = self.csl

        exposure = self.exposure

        format_: str | Unset = UNSET
        if not isinstance(self.format_, Unset):
            format_ = self.format_.value


        fps: float | None | Unset
        if isinstance(self.fps, Unset):
            fps = UNSET
        else:
            fps = self.fps

        frames: int | None | Unset
        if isinstance(self.frames, Unset):
            frames = UNSET
        else:
            frames = self.frames

        ground = self.ground

        height: int | None | Unset
        if isinstance(self.height, Unset):
            height = UNSET
        else:
            height = self.height

        layers = self.layers

        lights: list[dict[str, Any]] | None | Unset
        if isinstance(self.lights, Unset):
            lights = UNSET
        elif isinstance(self.lights, list):
            lights = []
            for lights_type_0_item_data in self.lights:
                lights_type_0_item: dict[str, Any]
                if isinstance(lights_type_0_item_data, LightDescType0):
                    lights_type_0_item = lights_type_0_item_data.to_dict()
                elif isinstance(lights_type_0_item_data, LightDescType1):
                    lights_type_0_item = lights_type_0_item_data.to_dict()
                elif isinstance(lights_type_0_item_data, LightDescType2):
                    lights_type_0_item = lights_type_0_item_data.to_dict()
                elif isinstance(lights_type_0_item_data, LightDescType3):
                    lights_type_0_item = lights_type_0_item_data.to_dict()
                else:
                    lights_type_0_item = lights_type_0_item_data.to_dict()

                lights.append(lights_type_0_item)


        else:
            lights = self.lights

        method: str | Unset = UNSET
        if not isinstance(self.method, Unset):
            method = self.method.value


        photons: int | None | Unset
        if isinstance(self.photons, Unset):
            photons = UNSET
        else:
            photons = self.photons

        pinhole: dict[str, Any] | None | Unset
        if isinstance(self.pinhole, Unset):
            pinhole = UNSET
        elif isinstance(self.pinhole, PinholeOptions):
            pinhole = self.pinhole.to_dict()
        else:
            pinhole = self.pinhole

        progressive: dict[str, Any] | None | Unset
        if isinstance(self.progressive, Unset):
            progressive = UNSET
        elif isinstance(self.progressive, ProgressiveOptions):
            progressive = self.progressive.to_dict()
        else:
            progressive = self.progressive

        refine: bool | None | Unset
        if isinstance(self.refine, Unset):
            refine = UNSET
        else:
            refine = self.refine

        seed: int | None | Unset
        if isinstance(self.seed, Unset):
            seed = UNSET
        else:
            seed = self.seed

        spp: int | None | Unset
        if isinstance(self.spp, Unset):
            spp = UNSET
        else:
            spp = self.spp

        time: float | None | Unset
        if isinstance(self.time, Unset):
            time = UNSET
        else:
            time = self.time

        tone_map: None | str | Unset
        if isinstance(self.tone_map, Unset):
            tone_map = UNSET
        elif isinstance(self.tone_map, ToneMap):
            tone_map = self.tone_map.value
        else:
            tone_map = self.tone_map

        volume_bounces: int | None | Unset
        if isinstance(self.volume_bounces, Unset):
            volume_bounces = UNSET
        else:
            volume_bounces = self.volume_bounces

        wait = self.wait

        water: dict[str, Any] | None | Unset
        if isinstance(self.water, Unset):
            water = UNSET
        elif isinstance(self.water, WaterOptions):
            water = self.water.to_dict()
        else:
            water = self.water

        water_mode: None | str | Unset
        if isinstance(self.water_mode, Unset):
            water_mode = UNSET
        elif isinstance(self.water_mode, Mode):
            water_mode = self.water_mode.value
        else:
            water_mode = self.water_mode

        width: int | None | Unset
        if isinstance(self.width, Unset):
            width = UNSET
        else:
            width = self.width


        field_dict: dict[str, Any] = {}

        field_dict.update({
            "scene": scene,
        })
        if beams is not UNSET:
            field_dict["beams"] = beams
        if camera is not UNSET:
            field_dict["camera"] = camera
        if check is not UNSET:
            field_dict["check"] = check
        if component is not UNSET:
            field_dict["component"] = component
        if csl is not UNSET:
            field_dict["csl"] = csl
        if exposure is not UNSET:
            field_dict["exposure"] = exposure
        if format_ is not UNSET:
            field_dict["format"] = format_
        if fps is not UNSET:
            field_dict["fps"] = fps
        if frames is not UNSET:
            field_dict["frames"] = frames
        if ground is not UNSET:
            field_dict["ground"] = ground
        if height is not UNSET:
            field_dict["height"] = height
        if layers is not UNSET:
            field_dict["layers"] = layers
        if lights is not UNSET:
            field_dict["lights"] = lights
        if method is not UNSET:
            field_dict["method"] = method
        if photons is not UNSET:
            field_dict["photons"] = photons
        if pinhole is not UNSET:
            field_dict["pinhole"] = pinhole
        if progressive is not UNSET:
            field_dict["progressive"] = progressive
        if refine is not UNSET:
            field_dict["refine"] = refine
        if seed is not UNSET:
            field_dict["seed"] = seed
        if spp is not UNSET:
            field_dict["spp"] = spp
        if time is not UNSET:
            field_dict["time"] = time
        if tone_map is not UNSET:
            field_dict["tone_map"] = tone_map
        if volume_bounces is not UNSET:
            field_dict["volume_bounces"] = volume_bounces
        if wait is not UNSET:
            field_dict["wait"] = wait
        if water is not UNSET:
            field_dict["water"] = water
        if water_mode is not UNSET:
            field_dict["water_mode"] = water_mode
        if width is not UNSET:
            field_dict["width"] = width

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.beams_options import BeamsOptions # noqa: PLC0415
        from ..models.camera_desc import CameraDesc # noqa: PLC0415
        from ..models.csl_params import CslParams # noqa: PLC0415
        from ..models.light_desc_type_0 import LightDescType0 # noqa: PLC0415
        from ..models.light_desc_type_1 import LightDescType1 # noqa: PLC0415
        from ..models.light_desc_type_2 import LightDescType2 # noqa: PLC0415
        from ..models.light_desc_type_3 import LightDescType3 # noqa: PLC0415
        from ..models.light_desc_type_4 import LightDescType4 # noqa: PLC0415
        from ..models.pinhole_options import PinholeOptions # noqa: PLC0415
        from ..models.progressive_options import ProgressiveOptions # noqa: PLC0415
        from ..models.scene import Scene # noqa: PLC0415
        from ..models.water_options import WaterOptions # noqa: PLC0415
        d = dict(src_dict)
        def _parse_scene(data: object) -> Scene | str:
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                componentsschemas_scene_ref_type_0 = Scene.from_dict(data)



                return componentsschemas_scene_ref_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(Scene | str, data)

        scene = _parse_scene(d.pop("scene"))


        def _parse_beams(data: object) -> BeamsOptions | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                beams_type_0 = BeamsOptions.from_dict(data)



                return beams_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(BeamsOptions | None | Unset, data)

        beams = _parse_beams(d.pop("beams", UNSET))


        def _parse_camera(data: object) -> CameraDesc | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                camera_type_0 = CameraDesc.from_dict(data)



                return camera_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(CameraDesc | None | Unset, data)

        camera = _parse_camera(d.pop("camera", UNSET))


        def _parse_check(data: object) -> bool | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(bool | None | Unset, data)

        check = _parse_check(d.pop("check", UNSET))


        _component = d.pop("component", UNSET)
        component: Component | Unset
        if isinstance(_component,  Unset):
            component = UNSET
        else:
            component = Component(_component)




        def _parse_csl(data: object) -> CslParams | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                csl_type_0 = CslParams.from_dict(data)



                return csl_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(CslParams | None | Unset, data)

        csl = _parse_csl(d.pop("csl", UNSET))


        exposure = d.pop("exposure", UNSET)

        _format_ = d.pop("format", UNSET)
        format_: Format | Unset
        if isinstance(_format_,  Unset):
            format_ = UNSET
        else:
            format_ = Format(_format_)




        def _parse_fps(data: object) -> float | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(float | None | Unset, data)

        fps = _parse_fps(d.pop("fps", UNSET))


        def _parse_frames(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        frames = _parse_frames(d.pop("frames", UNSET))


        ground = d.pop("ground", UNSET)

        def _parse_height(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        height = _parse_height(d.pop("height", UNSET))


        layers = d.pop("layers", UNSET)

        def _parse_lights(data: object) -> list[LightDescType0 | LightDescType1 | LightDescType2 | LightDescType3 | LightDescType4] | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, list):
                    raise TypeError()
                lights_type_0 = []
                _lights_type_0 = data
                for lights_type_0_item_data in (_lights_type_0):
                    def _parse_lights_type_0_item(data: object) -> LightDescType0 | LightDescType1 | LightDescType2 | LightDescType3 | LightDescType4:
                        try:
                            if not isinstance(data, dict):
                                raise TypeError()
                            componentsschemas_light_desc_type_0 = LightDescType0.from_dict(data)



                            return componentsschemas_light_desc_type_0
                        except (TypeError, ValueError, AttributeError, KeyError):
                            pass
                        try:
                            if not isinstance(data, dict):
                                raise TypeError()
                            componentsschemas_light_desc_type_1 = LightDescType1.from_dict(data)



                            return componentsschemas_light_desc_type_1
                        except (TypeError, ValueError, AttributeError, KeyError):
                            pass
                        try:
                            if not isinstance(data, dict):
                                raise TypeError()
                            componentsschemas_light_desc_type_2 = LightDescType2.from_dict(data)



                            return componentsschemas_light_desc_type_2
                        except (TypeError, ValueError, AttributeError, KeyError):
                            pass
                        try:
                            if not isinstance(data, dict):
                                raise TypeError()
                            componentsschemas_light_desc_type_3 = LightDescType3.from_dict(data)



                            return componentsschemas_light_desc_type_3
                        except (TypeError, ValueError, AttributeError, KeyError):
                            pass
                        if not isinstance(data, dict):
                            raise TypeError()
                        componentsschemas_light_desc_type_4 = LightDescType4.from_dict(data)



                        return componentsschemas_light_desc_type_4

                    lights_type_0_item = _parse_lights_type_0_item(lights_type_0_item_data)

                    lights_type_0.append(lights_type_0_item)

                return lights_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(list[LightDescType0 | LightDescType1 | LightDescType2 | LightDescType3 | LightDescType4] | None | Unset, data)

        lights = _parse_lights(d.pop("lights", UNSET))


        _method = d.pop("method", UNSET)
        method: Method | Unset
        if isinstance(_method,  Unset):
            method = UNSET
        else:
            method = Method(_method)




        def _parse_photons(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        photons = _parse_photons(d.pop("photons", UNSET))


        def _parse_pinhole(data: object) -> None | PinholeOptions | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                pinhole_type_0 = PinholeOptions.from_dict(data)



                return pinhole_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(None | PinholeOptions | Unset, data)

        pinhole = _parse_pinhole(d.pop("pinhole", UNSET))


        def _parse_progressive(data: object) -> None | ProgressiveOptions | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                progressive_type_0 = ProgressiveOptions.from_dict(data)



                return progressive_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(None | ProgressiveOptions | Unset, data)

        progressive = _parse_progressive(d.pop("progressive", UNSET))


        def _parse_refine(data: object) -> bool | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(bool | None | Unset, data)

        refine = _parse_refine(d.pop("refine", UNSET))


        def _parse_seed(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        seed = _parse_seed(d.pop("seed", UNSET))


        def _parse_spp(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        spp = _parse_spp(d.pop("spp", UNSET))


        def _parse_time(data: object) -> float | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(float | None | Unset, data)

        time = _parse_time(d.pop("time", UNSET))


        def _parse_tone_map(data: object) -> None | ToneMap | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, str):
                    raise TypeError()
                tone_map_type_0 = ToneMap(data)



                return tone_map_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(None | ToneMap | Unset, data)

        tone_map = _parse_tone_map(d.pop("tone_map", UNSET))


        def _parse_volume_bounces(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        volume_bounces = _parse_volume_bounces(d.pop("volume_bounces", UNSET))


        wait = d.pop("wait", UNSET)

        def _parse_water(data: object) -> None | Unset | WaterOptions:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                water_type_0 = WaterOptions.from_dict(data)



                return water_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(None | Unset | WaterOptions, data)

        water = _parse_water(d.pop("water", UNSET))


        def _parse_water_mode(data: object) -> Mode | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, str):
                    raise TypeError()
                water_mode_type_0 = Mode(data)



                return water_mode_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(Mode | None | Unset, data)

        water_mode = _parse_water_mode(d.pop("water_mode", UNSET))


        def _parse_width(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        width = _parse_width(d.pop("width", UNSET))


        render_request = cls(
            scene=scene,
            beams=beams,
            camera=camera,
            check=check,
            component=component,
            csl=csl,
            exposure=exposure,
            format_=format_,
            fps=fps,
            frames=frames,
            ground=ground,
            height=height,
            layers=layers,
            lights=lights,
            method=method,
            photons=photons,
            pinhole=pinhole,
            progressive=progressive,
            refine=refine,
            seed=seed,
            spp=spp,
            time=time,
            tone_map=tone_map,
            volume_bounces=volume_bounces,
            wait=wait,
            water=water,
            water_mode=water_mode,
            width=width,
        )

        return render_request

