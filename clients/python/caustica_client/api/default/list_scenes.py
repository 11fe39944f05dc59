from http import HTTPStatus
from typing import Any, cast
from urllib.parse import quote

import httpx

from ...client import AuthenticatedClient, Client
from ...types import Response, UNSET
from ... import errors

from ...models.problem import Problem
from ...models.scene_summary_page import SceneSummaryPage
from ...types import UNSET, Unset
from typing import cast



def _get_kwargs(
    *,
    page_size: int | Unset = 20,
    page_token: str | Unset = UNSET,
    created_since: int | Unset = UNSET,

) -> dict[str, Any]:
    

    

    params: dict[str, Any] = {}

    params["page_size"] = page_size

    params["page_token"] = page_token

    params["created_since"] = created_since


    params = {k: v for k, v in params.items() if v is not UNSET and v is not None}


    _kwargs: dict[str, Any] = {
        "method": "get",
        "url": "/v1/scenes",
        "params": params,
    }


    return _kwargs



def _parse_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Problem | SceneSummaryPage | None:
    if response.status_code == 200:
        response_200 = SceneSummaryPage.from_dict(response.json())



        return response_200

    if response.status_code == 400:
        response_400 = Problem.from_dict(response.json())



        return response_400

    if response.status_code == 401:
        response_401 = Problem.from_dict(response.json())



        return response_401

    if response.status_code == 414:
        response_414 = Problem.from_dict(response.json())



        return response_414

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


def _build_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Response[Problem | SceneSummaryPage]:
    return Response(
        status_code=HTTPStatus(response.status_code),
        content=response.content,
        headers=response.headers,
        parsed=_parse_response(client=client, response=response),
    )


def sync_detailed(
    *,
    client: AuthenticatedClient | Client,
    page_size: int | Unset = 20,
    page_token: str | Unset = UNSET,
    created_since: int | Unset = UNSET,

) -> Response[Problem | SceneSummaryPage]:
    """ Stored scenes, newest first

     What the caller's key holds (an admin key, or a server without keys: everything), a page at a time;
    `next_page_token` fetches the next page and is null on the last. An unknown or inapplicable
    parameter, or a bad value, is a 422 naming it in `field`.

    Args:
        page_size (int | Unset):  Default: 20.
        page_token (str | Unset):
        created_since (int | Unset):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[Problem | SceneSummaryPage]
     """


    kwargs = _get_kwargs(
        page_size=page_size,
page_token=page_token,
created_since=created_since,

    )

    response = client.get_httpx_client().request(
        **kwargs,
    )

    return _build_response(client=client, response=response)

def sync(
    *,
    client: AuthenticatedClient | Client,
    page_size: int | Unset = 20,
    page_token: str | Unset = UNSET,
    created_since: int | Unset = UNSET,

) -> Problem | SceneSummaryPage | None:
    """ Stored scenes, newest first

     What the caller's key holds (an admin key, or a server without keys: everything), a page at a time;
    `next_page_token` fetches the next page and is null on the last. An unknown or inapplicable
    parameter, or a bad value, is a 422 naming it in `field`.

    Args:
        page_size (int | Unset):  Default: 20.
        page_token (str | Unset):
        created_since (int | Unset):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Problem | SceneSummaryPage
     """


    return sync_detailed(
        client=client,
page_size=page_size,
page_token=page_token,
created_since=created_since,

    ).parsed

async def asyncio_detailed(
    *,
    client: AuthenticatedClient | Client,
    page_size: int | Unset = 20,
    page_token: str | Unset = UNSET,
    created_since: int | Unset = UNSET,

) -> Response[Problem | SceneSummaryPage]:
    """ Stored scenes, newest first

     What the caller's key holds (an admin key, or a server without keys: everything), a page at a time;
    `next_page_token` fetches the next page and is null on the last. An unknown or inapplicable
    parameter, or a bad value, is a 422 naming it in `field`.

    Args:
        page_size (int | Unset):  Default: 20.
        page_token (str | Unset):
        created_since (int | Unset):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[Problem | SceneSummaryPage]
     """


    kwargs = _get_kwargs(
        page_size=page_size,
page_token=page_token,
created_since=created_since,

    )

    response = await client.get_async_httpx_client().request(
        **kwargs
    )

    return _build_response(client=client, response=response)

async def asyncio(
    *,
    client: AuthenticatedClient | Client,
    page_size: int | Unset = 20,
    page_token: str | Unset = UNSET,
    created_since: int | Unset = UNSET,

) -> Problem | SceneSummaryPage | None:
    """ Stored scenes, newest first

     What the caller's key holds (an admin key, or a server without keys: everything), a page at a time;
    `next_page_token` fetches the next page and is null on the last. An unknown or inapplicable
    parameter, or a bad value, is a 422 naming it in `field`.

    Args:
        page_size (int | Unset):  Default: 20.
        page_token (str | Unset):
        created_since (int | Unset):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Problem | SceneSummaryPage
     """


    return (await asyncio_detailed(
        client=client,
page_size=page_size,
page_token=page_token,
created_since=created_since,

    )).parsed
