from http import HTTPStatus
from typing import Any, cast
from urllib.parse import quote

import httpx

from ...client import AuthenticatedClient, Client
from ...types import Response, UNSET
from ... import errors

from ...models.csl_bake_request import CslBakeRequest
from ...models.job import Job
from ...models.problem import Problem
from ...models.reference_bake_request import ReferenceBakeRequest
from ...models.transport_bake_request import TransportBakeRequest
from ...types import UNSET, Unset
from typing import cast



def _get_kwargs(
    *,
    body: CslBakeRequest | ReferenceBakeRequest | TransportBakeRequest,
    idempotency_key: str | Unset = UNSET,

) -> dict[str, Any]:
    headers: dict[str, Any] = {}
    if not isinstance(idempotency_key, Unset):
        headers["Idempotency-Key"] = idempotency_key



    

    

    _kwargs: dict[str, Any] = {
        "method": "post",
        "url": "/v1/bakes",
    }

    
    if isinstance(body, CslBakeRequest):
        _kwargs["json"] = body.to_dict()
    elif isinstance(body, TransportBakeRequest):
        _kwargs["json"] = body.to_dict()
    else:
        _kwargs["json"] = body.to_dict()


    headers["Content-Type"] = "application/json"

    _kwargs["headers"] = headers
    return _kwargs



def _parse_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Job | Problem | None:
    if response.status_code == 202:
        response_202 = Job.from_dict(response.json())



        return response_202

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


def _build_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Response[Job | Problem]:
    return Response(
        status_code=HTTPStatus(response.status_code),
        content=response.content,
        headers=response.headers,
        parsed=_parse_response(client=client, response=response),
    )


def sync_detailed(
    *,
    client: AuthenticatedClient | Client,
    body: CslBakeRequest | ReferenceBakeRequest | TransportBakeRequest,
    idempotency_key: str | Unset = UNSET,

) -> Response[Job | Problem]:
    """ Start (or find) a bake

     Idempotent: the same scene, object, method and parameters give the same job id, and an
    `Idempotency-Key` header returns the job first created with it. A failed or canceled
    bake asked again runs again. Methods: `reference` (a CPU ground-truth render of the
    scene, every component as a layer of one EXR).

    Args:
        idempotency_key (str | Unset):
        body (CslBakeRequest | ReferenceBakeRequest | TransportBakeRequest): The body of `POST
            /v1/bakes`: exactly one of `scene` and `scene_id`, the object baked, and
            the method with its parameters.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[Job | Problem]
     """


    kwargs = _get_kwargs(
        body=body,
idempotency_key=idempotency_key,

    )

    response = client.get_httpx_client().request(
        **kwargs,
    )

    return _build_response(client=client, response=response)

def sync(
    *,
    client: AuthenticatedClient | Client,
    body: CslBakeRequest | ReferenceBakeRequest | TransportBakeRequest,
    idempotency_key: str | Unset = UNSET,

) -> Job | Problem | None:
    """ Start (or find) a bake

     Idempotent: the same scene, object, method and parameters give the same job id, and an
    `Idempotency-Key` header returns the job first created with it. A failed or canceled
    bake asked again runs again. Methods: `reference` (a CPU ground-truth render of the
    scene, every component as a layer of one EXR).

    Args:
        idempotency_key (str | Unset):
        body (CslBakeRequest | ReferenceBakeRequest | TransportBakeRequest): The body of `POST
            /v1/bakes`: exactly one of `scene` and `scene_id`, the object baked, and
            the method with its parameters.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Job | Problem
     """


    return sync_detailed(
        client=client,
body=body,
idempotency_key=idempotency_key,

    ).parsed

async def asyncio_detailed(
    *,
    client: AuthenticatedClient | Client,
    body: CslBakeRequest | ReferenceBakeRequest | TransportBakeRequest,
    idempotency_key: str | Unset = UNSET,

) -> Response[Job | Problem]:
    """ Start (or find) a bake

     Idempotent: the same scene, object, method and parameters give the same job id, and an
    `Idempotency-Key` header returns the job first created with it. A failed or canceled
    bake asked again runs again. Methods: `reference` (a CPU ground-truth render of the
    scene, every component as a layer of one EXR).

    Args:
        idempotency_key (str | Unset):
        body (CslBakeRequest | ReferenceBakeRequest | TransportBakeRequest): The body of `POST
            /v1/bakes`: exactly one of `scene` and `scene_id`, the object baked, and
            the method with its parameters.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[Job | Problem]
     """


    kwargs = _get_kwargs(
        body=body,
idempotency_key=idempotency_key,

    )

    response = await client.get_async_httpx_client().request(
        **kwargs
    )

    return _build_response(client=client, response=response)

async def asyncio(
    *,
    client: AuthenticatedClient | Client,
    body: CslBakeRequest | ReferenceBakeRequest | TransportBakeRequest,
    idempotency_key: str | Unset = UNSET,

) -> Job | Problem | None:
    """ Start (or find) a bake

     Idempotent: the same scene, object, method and parameters give the same job id, and an
    `Idempotency-Key` header returns the job first created with it. A failed or canceled
    bake asked again runs again. Methods: `reference` (a CPU ground-truth render of the
    scene, every component as a layer of one EXR).

    Args:
        idempotency_key (str | Unset):
        body (CslBakeRequest | ReferenceBakeRequest | TransportBakeRequest): The body of `POST
            /v1/bakes`: exactly one of `scene` and `scene_id`, the object baked, and
            the method with its parameters.

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Job | Problem
     """


    return (await asyncio_detailed(
        client=client,
body=body,
idempotency_key=idempotency_key,

    )).parsed
