from http import HTTPStatus
from typing import Any, cast
from urllib.parse import quote

import httpx

from ...client import AuthenticatedClient, Client
from ...types import Response, UNSET
from ... import errors

from ...models.problem import Problem
from typing import cast



def _get_kwargs(
    id: str,

) -> dict[str, Any]:
    

    

    

    _kwargs: dict[str, Any] = {
        "method": "get",
        "url": "/v1/renders/{id}/events".format(id=quote(str(id), safe=""),),
    }


    return _kwargs



def _parse_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Problem | str | None:
    if response.status_code == 200:
        response_200 = response.text
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

    if response.status_code == 414:
        response_414 = Problem.from_dict(response.json())



        return response_414

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


def _build_response(*, client: AuthenticatedClient | Client, response: httpx.Response) -> Response[Problem | str]:
    return Response(
        status_code=HTTPStatus(response.status_code),
        content=response.content,
        headers=response.headers,
        parsed=_parse_response(client=client, response=response),
    )


def sync_detailed(
    id: str,
    *,
    client: AuthenticatedClient | Client,

) -> Response[Problem | str]:
    """ The render's live progress (server-sent events)

     A `text/event-stream`. Each `progress` event's data is a JSON object `{id, state,
    progress, stage, eta_ms}` (schema `ProgressEvent`), sent when one of them changes visibly (half a
    per cent, a
    new stage or state; at most ten a second). The stream ends with one `done` event whose
    data is the whole job (as `GET /v1/renders/{id}` answers it) once the job is finished,
    or `gone` (`{id}`) when it was deleted meanwhile; a finished job's stream is its `done`
    event alone. Comment lines keep an idle stream alive; server shutdown ends it. A
    stream lasts at most the server's stream lifetime (300 s by default), then ends
    without `done`; its first event's `retry:` (1 s) tells the client when to connect
    again (an `EventSource` does by itself). One client may follow 16 streams at once
    (then `429`, problem type `too-many`).

    Args:
        id (str):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[Problem | str]
     """


    kwargs = _get_kwargs(
        id=id,

    )

    response = client.get_httpx_client().request(
        **kwargs,
    )

    return _build_response(client=client, response=response)

def sync(
    id: str,
    *,
    client: AuthenticatedClient | Client,

) -> Problem | str | None:
    """ The render's live progress (server-sent events)

     A `text/event-stream`. Each `progress` event's data is a JSON object `{id, state,
    progress, stage, eta_ms}` (schema `ProgressEvent`), sent when one of them changes visibly (half a
    per cent, a
    new stage or state; at most ten a second). The stream ends with one `done` event whose
    data is the whole job (as `GET /v1/renders/{id}` answers it) once the job is finished,
    or `gone` (`{id}`) when it was deleted meanwhile; a finished job's stream is its `done`
    event alone. Comment lines keep an idle stream alive; server shutdown ends it. A
    stream lasts at most the server's stream lifetime (300 s by default), then ends
    without `done`; its first event's `retry:` (1 s) tells the client when to connect
    again (an `EventSource` does by itself). One client may follow 16 streams at once
    (then `429`, problem type `too-many`).

    Args:
        id (str):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Problem | str
     """


    return sync_detailed(
        id=id,
client=client,

    ).parsed

async def asyncio_detailed(
    id: str,
    *,
    client: AuthenticatedClient | Client,

) -> Response[Problem | str]:
    """ The render's live progress (server-sent events)

     A `text/event-stream`. Each `progress` event's data is a JSON object `{id, state,
    progress, stage, eta_ms}` (schema `ProgressEvent`), sent when one of them changes visibly (half a
    per cent, a
    new stage or state; at most ten a second). The stream ends with one `done` event whose
    data is the whole job (as `GET /v1/renders/{id}` answers it) once the job is finished,
    or `gone` (`{id}`) when it was deleted meanwhile; a finished job's stream is its `done`
    event alone. Comment lines keep an idle stream alive; server shutdown ends it. A
    stream lasts at most the server's stream lifetime (300 s by default), then ends
    without `done`; its first event's `retry:` (1 s) tells the client when to connect
    again (an `EventSource` does by itself). One client may follow 16 streams at once
    (then `429`, problem type `too-many`).

    Args:
        id (str):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Response[Problem | str]
     """


    kwargs = _get_kwargs(
        id=id,

    )

    response = await client.get_async_httpx_client().request(
        **kwargs
    )

    return _build_response(client=client, response=response)

async def asyncio(
    id: str,
    *,
    client: AuthenticatedClient | Client,

) -> Problem | str | None:
    """ The render's live progress (server-sent events)

     A `text/event-stream`. Each `progress` event's data is a JSON object `{id, state,
    progress, stage, eta_ms}` (schema `ProgressEvent`), sent when one of them changes visibly (half a
    per cent, a
    new stage or state; at most ten a second). The stream ends with one `done` event whose
    data is the whole job (as `GET /v1/renders/{id}` answers it) once the job is finished,
    or `gone` (`{id}`) when it was deleted meanwhile; a finished job's stream is its `done`
    event alone. Comment lines keep an idle stream alive; server shutdown ends it. A
    stream lasts at most the server's stream lifetime (300 s by default), then ends
    without `done`; its first event's `retry:` (1 s) tells the client when to connect
    again (an `EventSource` does by itself). One client may follow 16 streams at once
    (then `429`, problem type `too-many`).

    Args:
        id (str):

    Raises:
        errors.UnexpectedStatus: If the server returns an undocumented status code and Client.raise_on_unexpected_status is True.
        httpx.TimeoutException: If the request takes longer than Client.timeout.

    Returns:
        Problem | str
     """


    return (await asyncio_detailed(
        id=id,
client=client,

    )).parsed
