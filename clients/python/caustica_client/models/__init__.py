""" Contains all the data models used in inputs/outputs """

from .beams_options import BeamsOptions
from .beams_options_downsample import BeamsOptionsDownsample
from .beams_options_grid import BeamsOptionsGrid
from .bounds import Bounds
from .camera_desc import CameraDesc
from .compare_body import CompareBody
from .compare_response_200 import CompareResponse200
from .component import Component
from .create_scene_files_body import CreateSceneFilesBody
from .csl_bake_request import CslBakeRequest
from .csl_params import CslParams
from .csl_params_preset import CslParamsPreset
from .format_ import Format
from .healthz_response_200 import HealthzResponse200
from .job import Job
from .job_info import JobInfo
from .job_kind import JobKind
from .job_page import JobPage
from .job_params import JobParams
from .job_state import JobState
from .light_desc_type_0 import LightDescType0
from .light_desc_type_1 import LightDescType1
from .light_desc_type_2 import LightDescType2
from .light_desc_type_3 import LightDescType3
from .light_desc_type_4 import LightDescType4
from .list_bakes_method import ListBakesMethod
from .list_bakes_state import ListBakesState
from .list_renders_method import ListRendersMethod
from .list_renders_state import ListRendersState
from .material_desc_type_0 import MaterialDescType0
from .material_desc_type_1 import MaterialDescType1
from .material_desc_type_2 import MaterialDescType2
from .material_desc_type_3 import MaterialDescType3
from .medium_bounds_desc_type_0 import MediumBoundsDescType0
from .medium_bounds_desc_type_1 import MediumBoundsDescType1
from .medium_bounds_desc_type_2 import MediumBoundsDescType2
from .medium_desc import MediumDesc
from .method import Method
from .method_fit import MethodFit
from .mode import Mode
from .object_desc import ObjectDesc
from .object_info import ObjectInfo
from .openapi_response_200 import OpenapiResponse200
from .pinhole_options import PinholeOptions
from .problem import Problem
from .progress_event import ProgressEvent
from .progressive_options import ProgressiveOptions
from .readyz_response_200 import ReadyzResponse200
from .readyz_response_200_queued import ReadyzResponse200Queued
from .readyz_response_200_running import ReadyzResponse200Running
from .reference_bake_request import ReferenceBakeRequest
from .reference_params import ReferenceParams
from .render_request import RenderRequest
from .scene import Scene
from .scene_info import SceneInfo
from .scene_info_scene import SceneInfoScene
from .scene_materials import SceneMaterials
from .scene_summary import SceneSummary
from .scene_summary_page import SceneSummaryPage
from .shape_desc_type_0 import ShapeDescType0
from .shape_desc_type_1 import ShapeDescType1
from .shape_desc_type_2 import ShapeDescType2
from .shape_desc_type_3 import ShapeDescType3
from .shape_desc_type_4 import ShapeDescType4
from .shape_desc_type_5 import ShapeDescType5
from .shape_desc_type_6 import ShapeDescType6
from .shape_desc_type_7 import ShapeDescType7
from .strategy import Strategy
from .timing import Timing
from .tone_map import ToneMap
from .transform_desc import TransformDesc
from .transport_bake_request import TransportBakeRequest
from .transport_params import TransportParams
from .variant import Variant
from .water_options import WaterOptions
from .wave_desc import WaveDesc
from .waves_desc_type_0 import WavesDescType0
from .waves_desc_type_1 import WavesDescType1

__all__ = (
    "BeamsOptions",
    "BeamsOptionsDownsample",
    "BeamsOptionsGrid",
    "Bounds",
    "CameraDesc",
    "CompareBody",
    "CompareResponse200",
    "Component",
    "CreateSceneFilesBody",
    "CslBakeRequest",
    "CslParams",
    "CslParamsPreset",
    "Format",
    "HealthzResponse200",
    "Job",
    "JobInfo",
    "JobKind",
    "JobPage",
    "JobParams",
    "JobState",
    "LightDescType0",
    "LightDescType1",
    "LightDescType2",
    "LightDescType3",
    "LightDescType4",
    "ListBakesMethod",
    "ListBakesState",
    "ListRendersMethod",
    "ListRendersState",
    "MaterialDescType0",
    "MaterialDescType1",
    "MaterialDescType2",
    "MaterialDescType3",
    "MediumBoundsDescType0",
    "MediumBoundsDescType1",
    "MediumBoundsDescType2",
    "MediumDesc",
    "Method",
    "MethodFit",
    "Mode",
    "ObjectDesc",
    "ObjectInfo",
    "OpenapiResponse200",
    "PinholeOptions",
    "Problem",
    "ProgressEvent",
    "ProgressiveOptions",
    "ReadyzResponse200",
    "ReadyzResponse200Queued",
    "ReadyzResponse200Running",
    "ReferenceBakeRequest",
    "ReferenceParams",
    "RenderRequest",
    "Scene",
    "SceneInfo",
    "SceneInfoScene",
    "SceneMaterials",
    "SceneSummary",
    "SceneSummaryPage",
    "ShapeDescType0",
    "ShapeDescType1",
    "ShapeDescType2",
    "ShapeDescType3",
    "ShapeDescType4",
    "ShapeDescType5",
    "ShapeDescType6",
    "ShapeDescType7",
    "Strategy",
    "Timing",
    "ToneMap",
    "TransformDesc",
    "TransportBakeRequest",
    "TransportParams",
    "Variant",
    "WaterOptions",
    "WaveDesc",
    "WavesDescType0",
    "WavesDescType1",
)
