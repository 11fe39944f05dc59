from http import HTTPStatus
from typing import Any, cast
from urllib.parse import quote

import httpx

from ...client import AuthenticatedClient, Client
from ...types import Response, UNSET
from ... import errors

from ...models.job import Job
from ...models.problem import Problem
from ...models.render_request import RenderRequest
from ...types import File, FileTypes
from ...types import UNSET, Unset
from io import BytesIO
from typing import cast



def _get_kwargs(
    *,
    body: RenderRequest,
    idempotency_key: str | Unset = UNSET,
    accept: str | Unset = UNSET,

) -> dict[str, Any]:
    headers: dict[str, Any] = {}
    if not isinstance(idempotency_key, Unset):
        headers["Idempotency-Key"] = idempotency_key

    if not isinstance(accept, Unset):
        headers["Accept"] = accept



    

    

    _kwargs: dict[str, Any] = {
        "method": "post",
        "url": "/v1/renders",
    }

    _kwargs["json"] = body.to_dict()

    headers["Content-Type"] = "application/json"

    _kwargs["headers"] = headers
    return _kwargs



def _parse_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> File | Job | Problem | None:
    if response.status_code == 200:
        response_200 = File(
             payload = BytesIO(response.content)
        )



        return response_200

    if response.status_code == 202:
        response_202 = Job.from_dict(response.json())



        return response_202

    if response.status_code == 400:
        response_400 = Problem.from_dict(response.json())



        return response_400

    if response.status_code == 401:
        response_401 = Problem.from_dict(response.json())



        return response_401

    if response.status_code == 406:
        response_406 = Problem.from_dict(response.json())



        return response_406

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

    if response.status_code == 504:
        response_504 = Problem.from_dict(response.json())



        return response_504

    if response.status_code == 507:
        response_507 = Problem.from_dict(response.json())



        return response_507

    if client.raise_on_unexpected_status:
        raise errors.UnexpectedStatus(response.status_code, response.content)
    else:
        return None


def _build_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Response[File | Job | Problem]:
    return Response(
        status_code=HTTPStatus(response.status_code),
        content=response.content,
        headers=response.headers,
        parsed=_parse_response(client=client, response=response),
    )


def sync_detailed(
    *,
    client: AuthenticatedClient | Client,
    body: RenderRequest,
    idempotency_key: str | Unset = UNSET,
    accept: str | Unset = UNSET,

) -> Response[File | Job | Problem]:
    """ Render a frame

     Waits for the image by default and answers `200` with it, a `Server-Timing` header with
    every stage (queue, bvh/photons/camera or prepare/gpu passes/readback, check, encode,
    request), a `Caustica-Warning` header for each warning (e.g. why the caustics are black,
    a poor self-check) and `Location` of the render record. Past the server's wait (or with
    `wait: false`) it answers `202` with the job. Without `method`, `auto` picks one from
    the scene (the fastest measured within 0.10 of the reference on scenes of its kind; the
    record's `info.reason` and `info.statistics.auto` say which, why, and the error to
    expect). The baked methods (`csl`, `transport`) bake first on the CPU pool, or find an
    earlier bake by content hash (the `bake` stage of `Server-Timing`;
    `info.statistics.bakes[].cached`), and check their frame against a short reference
    (`info.statistics.check`).

    Args:
        idempotency_key (str | Unset):
        accept (str | Unset):
        body (RenderRequest): The body of `POST /v1/renders`: the scene, the method, and the
            render's parameters (each
            method's own options in the field named after it: `csl`, `pinhole`, `water`, `beams`,
            `progressive`; a method's options given to another method are refused with 422).

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[File | Job | Problem]
     """


    kwargs = _get_kwargs(
        body=body,
idempotency_key=idempotency_key,
accept=accept,

    )

    response = client.get_httpx_client().request(
        **kwargs,
    )

    return _build_response(client=client, response=response)

def sync(
    *,
    client: AuthenticatedClient | Client,
    body: RenderRequest,
    idempotency_key: str | Unset = UNSET,
    accept: str | Unset = UNSET,

) -> File | Job | Problem | None:
    """ Render a frame

     Waits for the image by default and answers `200` with it, a `Server-Timing` header with
    every stage (queue, bvh/photons/camera or prepare/gpu passes/readback, check, encode,
    request), a `Caustica-Warning` header for each warning (e.g. why the caustics are black,
    a poor self-check) and `Location` of the render record. Past the server's wait (or with
    `wait: false`) it answers `202` with the job. Without `method`, `auto` picks one from
    the scene (the fastest measured within 0.10 of the reference on scenes of its kind; the
    record's `info.reason` and `info.statistics.auto` say which, why, and the error to
    expect). The baked methods (`csl`, `transport`) bake first on the CPU pool, or find an
    earlier bake by content hash (the `bake` stage of `Server-Timing`;
    `info.statistics.bakes[].cached`), and check their frame against a short reference
    (`info.statistics.check`).

    Args:
        idempotency_key (str | Unset):
        accept (str | Unset):
        body (RenderRequest): The body of `POST /v1/renders`: the scene, the method, and the
            render's parameters (each
            method's own options in the field named after it: `csl`, `pinhole`, `water`, `beams`,
            `progressive`; a method's options given to another method are refused with 422).

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        File | Job | Problem
     """


    return sync_detailed(
        client=client,
body=body,
idempotency_key=idempotency_key,
accept=accept,

    ).parsed

async def asyncio_detailed(
    *,
    client: AuthenticatedClient | Client,
    body: RenderRequest,
    idempotency_key: str | Unset = UNSET,
    accept: str | Unset = UNSET,

) -> Response[File | Job | Problem]:
    """ Render a frame

     Waits for the image by default and answers `200` with it, a `Server-Timing` header with
    every stage (queue, bvh/photons/camera or prepare/gpu passes/readback, check, encode,
    request), a `Caustica-Warning` header for each warning (e.g. why the caustics are black,
    a poor self-check) and `Location` of the render record. Past the server's wait (or with
    `wait: false`) it answers `202` with the job. Without `method`, `auto` picks one from
    the scene (the fastest measured within 0.10 of the reference on scenes of its kind; the
    record's `info.reason` and `info.statistics.auto` say which, why, and the error to
    expect). The baked methods (`csl`, `transport`) bake first on the CPU pool, or find an
    earlier bake by content hash (the `bake` stage of `Server-Timing`;
    `info.statistics.bakes[].cached`), and check their frame against a short reference
    (`info.statistics.check`).

    Args:
        idempotency_key (str | Unset):
        accept (str | Unset):
        body (RenderRequest): The body of `POST /v1/renders`: the scene, the method, and the
            render's parameters (each
            method's own options in the field named after it: `csl`, `pinhole`, `water`, `beams`,
            `progressive`; a method's options given to another method are refused with 422).

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[File | Job | Problem]
     """


    kwargs = _get_kwargs(
        body=body,
idempotency_key=idempotency_key,
accept=accept,

    )

    response = await client.get_async_httpx_client().request(
        **kwargs
    )

    return _build_response(client=client, response=response)

async def asyncio(
    *,
    client: AuthenticatedClient | Client,
    body: RenderRequest,
    idempotency_key: str | Unset = UNSET,
    accept: str | Unset = UNSET,

) -> File | Job | Problem | None:
    """ Render a frame

     Waits for the image by default and answers `200` with it, a `Server-Timing` header with
    every stage (queue, bvh/photons/camera or prepare/gpu passes/readback, check, encode,
    request), a `Caustica-Warning` header for each warning (e.g. why the caustics are black,
    a poor self-check) and `Location` of the render record. Past the server's wait (or with
    `wait: false`) it answers `202` with the job. Without `method`, `auto` picks one from
    the scene (the fastest measured within 0.10 of the reference on scenes of its kind; the
    record's `info.reason` and `info.statistics.auto` say which, why, and the error to
    expect). The baked methods (`csl`, `transport`) bake first on the CPU pool, or find an
    earlier bake by content hash (the `bake` stage of `Server-Timing`;
    `info.statistics.bakes[].cached`), and check their frame against a short reference
    (`info.statistics.check`).

    Args:
        idempotency_key (str | Unset):
        accept (str | Unset):
        body (RenderRequest): The body of `POST /v1/renders`: the scene, the method, and the
            render's parameters (each
            method's own options in the field named after it: `csl`, `pinhole`, `water`, `beams`,
            `progressive`; a method's options given to another method are refused with 422).

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        File | Job | Problem
     """


    return (await asyncio_detailed(
        client=client,
body=body,
idempotency_key=idempotency_key,
accept=accept,

    )).parsed
