from http import HTTPStatus
from typing import Any, cast
from urllib.parse import quote

import httpx

from ...client import AuthenticatedClient, Client
from ...types import Unset
from ...types import Response, UNSET
from ... import errors

from ...models.create_scene_files_body import CreateSceneFilesBody
from ...models.problem import Problem
from ...models.scene import Scene
from ...models.scene_info import SceneInfo
from ...types import File, FileTypes
from io import BytesIO
from typing import cast



def _get_kwargs(
    *,
    body:    Scene  |     File  |     File  |     CreateSceneFilesBody  | Unset = UNSET,

) -> dict[str, Any]:
    headers: dict[str, Any] = {}


    

    

    _kwargs: dict[str, Any] = {
        "method": "post",
        "url": "/v1/scenes",
    }

    if isinstance(body, Scene):
        _kwargs["json"] = body.to_dict()

        headers["Content-Type"] = "application/json"
    if isinstance(body, File):
        _kwargs["content"] = body.payload
        headers["Content-Type"] = "model/gltf+json"
    if isinstance(body, File):
        _kwargs["content"] = body.payload
        headers["Content-Type"] = "model/gltf-binary"
    if isinstance(body, CreateSceneFilesBody):
        _kwargs["files"] = body.to_multipart()

        headers["Content-Type"] = "multipart/form-data; boundary=+++"

    _kwargs["headers"] = headers
    return _kwargs



def _parse_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Problem | SceneInfo | None:
    if response.status_code == 201:
        response_201 = SceneInfo.from_dict(response.json())



        return response_201

    if response.status_code == 400:
        response_400 = Problem.from_dict(response.json())



        return response_400

    if response.status_code == 401:
        response_401 = Problem.from_dict(response.json())



        return response_401

    if response.status_code == 408:
        response_408 = Problem.from_dict(response.json())



        return response_408

    if response.status_code == 413:
        response_413 = Problem.from_dict(response.json())



        return response_413

    if response.status_code == 414:
        response_414 = Problem.from_dict(response.json())



        return response_414

    if response.status_code == 415:
        response_415 = Problem.from_dict(response.json())



        return response_415

    if response.status_code == 422:
        response_422 = Problem.from_dict(response.json())



        return response_422

    if response.status_code == 429:
        response_429 = Problem.from_dict(response.json())



        return response_429

    if response.status_code == 431:
        response_431 = Problem.from_dict(response.json())



        return response_431

    if response.status_code == 500:
        response_500 = Problem.from_dict(response.json())



        return response_500

    if response.status_code == 503:
        response_503 = Problem.from_dict(response.json())



        return response_503

    if response.status_code == 507:
        response_507 = Problem.from_dict(response.json())



        return response_507

    if client.raise_on_unexpected_status:
        raise errors.UnexpectedStatus(response.status_code, response.content)
    else:
        return None


def _build_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Response[Problem | SceneInfo]:
    return Response(
        status_code=HTTPStatus(response.status_code),
        content=response.content,
        headers=response.headers,
        parsed=_parse_response(client=client, response=response),
    )


def sync_detailed(
    *,
    client: AuthenticatedClient | Client,
    body:    Scene  |     File  |     File  |     CreateSceneFilesBody  | Unset = UNSET,

) -> Response[Problem | SceneInfo]:
    """ Upload a scene

     Our scene JSON (`application/json`, see `api/scene.schema.json`), a glTF file as a
    whole scene (`model/gltf-binary` or `model/gltf+json` with embedded data; camera and
    lights from the file, else defaults with a warning), or `multipart/form-data` with a
    part named `scene` (the JSON) and one part per file it names (the part name is the
    file name used in the scene). glTF is read from the uploaded bytes only: external,
    absolute and `file:` URIs are refused.

    Args:
        body (Scene): A whole scene: one camera, the lights, named materials and objects.
        body (File):
        body (File):
        body (CreateSceneFilesBody):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[Problem | SceneInfo]
     """


    kwargs = _get_kwargs(
        body=body,

    )

    response = client.get_httpx_client().request(
        **kwargs,
    )

    return _build_response(client=client, response=response)

def sync(
    *,
    client: AuthenticatedClient | Client,
    body:    Scene  |     File  |     File  |     CreateSceneFilesBody  | Unset = UNSET,

) -> Problem | SceneInfo | None:
    """ Upload a scene

     Our scene JSON (`application/json`, see `api/scene.schema.json`), a glTF file as a
    whole scene (`model/gltf-binary` or `model/gltf+json` with embedded data; camera and
    lights from the file, else defaults with a warning), or `multipart/form-data` with a
    part named `scene` (the JSON) and one part per file it names (the part name is the
    file name used in the scene). glTF is read from the uploaded bytes only: external,
    absolute and `file:` URIs are refused.

    Args:
        body (Scene): A whole scene: one camera, the lights, named materials and objects.
        body (File):
        body (File):
        body (CreateSceneFilesBody):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Problem | SceneInfo
     """


    return sync_detailed(
        client=client,
body=body,

    ).parsed

async def asyncio_detailed(
    *,
    client: AuthenticatedClient | Client,
    body:    Scene  |     File  |     File  |     CreateSceneFilesBody  | Unset = UNSET,

) -> Response[Problem | SceneInfo]:
    """ Upload a scene

     Our scene JSON (`application/json`, see `api/scene.schema.json`), a glTF file as a
    whole scene (`model/gltf-binary` or `model/gltf+json` with embedded data; camera and
    lights from the file, else defaults with a warning), or `multipart/form-data` with a
    part named `scene` (the JSON) and one part per file it names (the part name is the
    file name used in the scene). glTF is read from the uploaded bytes only: external,
    absolute and `file:` URIs are refused.

    Args:
        body (Scene): A whole scene: one camera, the lights, named materials and objects.
        body (File):
        body (File):
        body (CreateSceneFilesBody):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[Problem | SceneInfo]
     """


    kwargs = _get_kwargs(
        body=body,

    )

    response = await client.get_async_httpx_client().request(
        **kwargs
    )

    return _build_response(client=client, response=response)

async def asyncio(
    *,
    client: AuthenticatedClient | Client,
    body:    Scene  |     File  |     File  |     CreateSceneFilesBody  | Unset = UNSET,

) -> Problem | SceneInfo | None:
    """ Upload a scene

     Our scene JSON (`application/json`, see `api/scene.schema.json`), a glTF file as a
    whole scene (`model/gltf-binary` or `model/gltf+json` with embedded data; camera and
    lights from the file, else defaults with a warning), or `multipart/form-data` with a
    part named `scene` (the JSON) and one part per file it names (the part name is the
    file name used in the scene). glTF is read from the uploaded bytes only: external,
    absolute and `file:` URIs are refused.

    Args:
        body (Scene): A whole scene: one camera, the lights, named materials and objects.
        body (File):
        body (File):
        body (CreateSceneFilesBody):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Problem | SceneInfo
     """


    return (await asyncio_detailed(
        client=client,
body=body,

    )).parsed
