from http import HTTPStatus
from typing import Any, cast
from urllib.parse import quote

import httpx

from ...client import AuthenticatedClient, Client
from ...types import Response, UNSET
from ... import errors

from ...models.compare_body import CompareBody
from ...models.compare_response_200 import CompareResponse200
from ...models.problem import Problem
from typing import cast



def _get_kwargs(
    *,
    body: CompareBody,

) -> dict[str, Any]:
    headers: dict[str, Any] = {}


    

    

    _kwargs: dict[str, Any] = {
        "method": "post",
        "url": "/v1/compare",
    }

    _kwargs["json"] = body.to_dict()

    headers["Content-Type"] = "application/json"

    _kwargs["headers"] = headers
    return _kwargs



def _parse_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> CompareResponse200 | Problem | None:
    if response.status_code == 200:
        response_200 = CompareResponse200.from_dict(response.json())



        return response_200

    if response.status_code == 400:
        response_400 = Problem.from_dict(response.json())



        return response_400

    if response.status_code == 401:
        response_401 = Problem.from_dict(response.json())



        return response_401

    if response.status_code == 404:
        response_404 = Problem.from_dict(response.json())



        return response_404

    if response.status_code == 409:
        response_409 = Problem.from_dict(response.json())



        return response_409

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

    if client.raise_on_unexpected_status:
        raise errors.UnexpectedStatus(response.status_code, response.content)
    else:
        return None


def _build_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Response[CompareResponse200 | Problem]:
    return Response(
        status_code=HTTPStatus(response.status_code),
        content=response.content,
        headers=response.headers,
        parsed=_parse_response(client=client, response=response),
    )


def sync_detailed(
    *,
    client: AuthenticatedClient | Client,
    body: CompareBody,

) -> Response[CompareResponse200 | Problem]:
    """ Two finished EXR renders compared, as `caustica compare` does

     The relative L1 (Σ|a−b| / Σ|b| after a 3×3 blur of both) and the flux ratio (Σa / Σb) of render `a`
    against render `b` (the reference), over the pixels whose 3×3 neighbourhood sees `object` through
    render a's camera: the figures `caustica compare a.exr b.exr --scene SCENE --object OBJECT --camera
    CAMERA` prints for the same images. Both renders must have succeeded (409 otherwise) with `format:
    exr` and be of one size (422 naming `a` or `b`). The comparison holds both images in memory (~160 B
    a pixel each) against the server's job memory: `503` no-memory with `Retry-After` when that does not
    fit beside the jobs', `422` too-big when it exceeds the whole budget.

    Args:
        body (CompareBody):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[CompareResponse200 | Problem]
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
    body: CompareBody,

) -> CompareResponse200 | Problem | None:
    """ Two finished EXR renders compared, as `caustica compare` does

     The relative L1 (Σ|a−b| / Σ|b| after a 3×3 blur of both) and the flux ratio (Σa / Σb) of render `a`
    against render `b` (the reference), over the pixels whose 3×3 neighbourhood sees `object` through
    render a's camera: the figures `caustica compare a.exr b.exr --scene SCENE --object OBJECT --camera
    CAMERA` prints for the same images. Both renders must have succeeded (409 otherwise) with `format:
    exr` and be of one size (422 naming `a` or `b`). The comparison holds both images in memory (~160 B
    a pixel each) against the server's job memory: `503` no-memory with `Retry-After` when that does not
    fit beside the jobs', `422` too-big when it exceeds the whole budget.

    Args:
        body (CompareBody):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        CompareResponse200 | Problem
     """


    return sync_detailed(
        client=client,
body=body,

    ).parsed

async def asyncio_detailed(
    *,
    client: AuthenticatedClient | Client,
    body: CompareBody,

) -> Response[CompareResponse200 | Problem]:
    """ Two finished EXR renders compared, as `caustica compare` does

     The relative L1 (Σ|a−b| / Σ|b| after a 3×3 blur of both) and the flux ratio (Σa / Σb) of render `a`
    against render `b` (the reference), over the pixels whose 3×3 neighbourhood sees `object` through
    render a's camera: the figures `caustica compare a.exr b.exr --scene SCENE --object OBJECT --camera
    CAMERA` prints for the same images. Both renders must have succeeded (409 otherwise) with `format:
    exr` and be of one size (422 naming `a` or `b`). The comparison holds both images in memory (~160 B
    a pixel each) against the server's job memory: `503` no-memory with `Retry-After` when that does not
    fit beside the jobs', `422` too-big when it exceeds the whole budget.

    Args:
        body (CompareBody):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[CompareResponse200 | Problem]
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
    body: CompareBody,

) -> CompareResponse200 | Problem | None:
    """ Two finished EXR renders compared, as `caustica compare` does

     The relative L1 (Σ|a−b| / Σ|b| after a 3×3 blur of both) and the flux ratio (Σa / Σb) of render `a`
    against render `b` (the reference), over the pixels whose 3×3 neighbourhood sees `object` through
    render a's camera: the figures `caustica compare a.exr b.exr --scene SCENE --object OBJECT --camera
    CAMERA` prints for the same images. Both renders must have succeeded (409 otherwise) with `format:
    exr` and be of one size (422 naming `a` or `b`). The comparison holds both images in memory (~160 B
    a pixel each) against the server's job memory: `503` no-memory with `Retry-After` when that does not
    fit beside the jobs', `422` too-big when it exceeds the whole budget.

    Args:
        body (CompareBody):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        CompareResponse200 | Problem
     """


    return (await asyncio_detailed(
        client=client,
body=body,

    )).parsed
