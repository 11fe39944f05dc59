"""Caustica from Python: a thin layer over the generated client.

``caustica_client`` is generated from ``api/openapi.yaml`` by openapi-python-client (see
``generate.sh``): typed models and one module per operation. This module adds only what the
generator cannot express: uploads of a glTF JSON file or of a scene with its files (the
generator sends every binary body as GLB and cannot stream multipart parts as files),
following a job's server-sent events, waiting for a render that answered 202, and errors as
exceptions carrying the problem.

    from caustica import Caustica
    c = Caustica("http://127.0.0.1:8080")            # api_key="..." where the server has keys
    scene = c.upload_scene("cup.glb")                  # or a dict, a .json or .gltf path
    png = c.render(scene.id, method="direct", out="cup.png")
    mirror = next(o.name for o in scene.objects if o.specular)
    job = c.bake(scene.id, mirror, "csl", params={"preset": "fast"}, progress=print)
"""

from __future__ import annotations

import json
import os
import time
import warnings
from typing import Any, Callable, Iterator

import httpx

from caustica_client import AuthenticatedClient, Client
from caustica_client.api.default import (
    cancel_bake,
    cancel_render,
    create_bake,
    create_scene,
    get_bake,
    get_bake_artifact,
    get_render,
    get_render_image,
    list_bakes,
    list_renders,
    list_scenes,
    render as render_op,
)
from caustica_client.models import (
    CslBakeRequest,
    Job,
    ListBakesMethod,
    ListBakesState,
    ListRendersMethod,
    ListRendersState,
    JobState,
    Problem,
    ReferenceBakeRequest,
    RenderRequest,
    Scene,
    SceneInfo,
    TransportBakeRequest,
)
from caustica_client.types import UNSET, File

__all__ = ["Caustica", "CausticaError", "CausticaWarning"]

_TERMINAL = {"succeeded", "failed", "canceled"}
_BAKE_REQUESTS = {
    "csl": CslBakeRequest,
    "transport": TransportBakeRequest,
    "reference": ReferenceBakeRequest,
}


class CausticaWarning(UserWarning):
    """What a render's answer warns of (its ``Caustica-Warning`` headers, the record's
    ``info.warnings``): why its caustics are black, a poor self-check..."""


class CausticaError(Exception):
    """An answer that was not a success: ``status`` and the RFC 9457 ``problem`` (``type``,
    ``title``, ``detail`` and, where a request field is at fault, ``field``)."""

    def __init__(self, status: int, problem: dict[str, Any]):
        self.status = status
        self.problem = problem
        self.type = problem.get("type")
        self.field = problem.get("field")
        super().__init__(f"{status} {problem.get('title', '')}: {problem.get('detail', '')}")


def _raise(response) -> None:
    """Raises CausticaError for a response (generated or httpx) that is not 2xx."""
    status = int(response.status_code)
    if 200 <= status < 300:
        return
    parsed = getattr(response, "parsed", None)
    if isinstance(parsed, Problem):
        raise CausticaError(status, parsed.to_dict())
    try:
        problem = json.loads(response.content)
    except ValueError:
        problem = {"detail": response.content[:200].decode("utf-8", "replace")}
    raise CausticaError(status, problem if isinstance(problem, dict) else {"detail": str(problem)})


class Caustica:
    """A Caustica server at ``base_url``; ``api_key`` where the server has keys."""

    def __init__(self, base_url: str, api_key: str | None = None, timeout: float = 600.0):
        t = httpx.Timeout(timeout)
        if api_key:
            self.client: Client | AuthenticatedClient = AuthenticatedClient(
                base_url=base_url, token=api_key, timeout=t
            )
        else:
            self.client = Client(base_url=base_url, timeout=t)
        self._headers = {"Authorization": f"Bearer {api_key}"} if api_key else {}

    def _http(self) -> httpx.Client:
        return self.client.get_httpx_client()

    # Scenes

    def upload_scene(self, scene: Any, files: dict[str, bytes] | None = None) -> SceneInfo:
        """Stores a scene: a dict (our scene JSON), a path to a ``.json``, ``.glb`` or
        ``.gltf`` file, or a dict with ``files`` (name -> bytes) the scene names."""
        if isinstance(scene, (str, os.PathLike)):
            path = os.fspath(scene)
            with open(path, "rb") as f:
                data = f.read()
            if path.endswith(".glb"):
                r = create_scene.sync_detailed(
                    client=self.client,
                    body=File(payload=data, file_name=os.path.basename(path), mime_type="model/gltf-binary"),
                )
                _raise(r)
                return r.parsed
            if path.endswith(".gltf"):
                # The generator sends every binary body with the last media type it lists.
                return self._post_scene(content=data, headers={"Content-Type": "model/gltf+json"})
            scene = json.loads(data)
        if files:
            parts = {"scene": (None, json.dumps(scene).encode(), "application/json")}
            for name, blob in files.items():
                parts[name] = (name, blob, "application/octet-stream")
            return self._post_scene(files=parts)
        r = create_scene.sync_detailed(client=self.client, body=Scene.from_dict(scene))
        _raise(r)
        return r.parsed

    def _post_scene(self, **kw) -> SceneInfo:
        r = self._http().post("/v1/scenes", **kw)
        _raise(r)
        return SceneInfo.from_dict(r.json())

    def scenes(self, created_since: int | None = None) -> Iterator[Any]:
        """Every stored scene the key holds, newest first (all pages)."""
        return self._pages(list_scenes, _filters(None, None, None, None, created_since))

    # Renders

    def render(self, scene: Any, out: str | None = None, idempotency_key: str | None = None, **params) -> bytes:
        """Renders ``scene`` (a stored scene's id, or a scene dict) and returns the image's
        bytes (PNG, or EXR with ``format="exr"``), also written to ``out`` when given. Keyword
        arguments are the render request's fields (``method``, ``width``, ``ground``...). A
        render that outlasts the server's wait is followed to its end. The render's warnings
        (why its caustics are black, say) are issued as ``CausticaWarning``s."""
        body = RenderRequest.from_dict({"scene": scene, **params})
        r = render_op.sync_detailed(
            client=self.client, body=body, idempotency_key=idempotency_key or UNSET
        )
        _raise(r)
        job = None
        if r.status_code == 202:
            job = self.wait(r.parsed.id)
            if job.state != JobState.SUCCEEDED:
                raise CausticaError(500, {"title": f"render {job.state.value}", "detail": job.error or ""})
            img = get_render_image.sync_detailed(job.id, client=self.client)
            _raise(img)
            data = img.content
        else:
            data = r.content
            if "caustica-warning" in r.headers:
                # The headers hold the warnings that fit a header; the record has them all.
                job = self.job(r.headers["location"].rsplit("/", 1)[-1])
        if job is not None:
            for w in job.info.to_dict().get("warnings") or []:
                warnings.warn(w, CausticaWarning, stacklevel=2)
        if out:
            with open(out, "wb") as f:
                f.write(data)
        return data

    def renders(self, state: str | None = None, method: str | None = None, created_since: int | None = None) -> Iterator[Job]:
        """Every render the key holds, newest first (all pages), optionally only those in
        ``state``, of ``method``, or created at or after ``created_since`` (ms since the epoch)."""
        return self._pages(list_renders, _filters(ListRendersState, ListRendersMethod, state, method, created_since))

    def cancel_render(self, job_id: str) -> Job:
        r = cancel_render.sync_detailed(job_id, client=self.client)
        _raise(r)
        return r.parsed

    # Bakes

    def bake(
        self,
        scene: Any,
        object: str,
        method: str,
        params: dict[str, Any] | None = None,
        wait: bool = True,
        progress: Callable[[dict[str, Any]], None] | None = None,
        idempotency_key: str | None = None,
    ) -> Job:
        """Starts (or finds) a bake of ``object`` in ``scene`` (an id or a scene dict). With
        ``wait``, follows its events (``progress`` gets each ``progress`` event's data) and
        returns the finished job."""
        body: dict[str, Any] = {"scene": scene, "object": object, "method": method}
        if params is not None:
            body["params"] = params
        model = _BAKE_REQUESTS.get(method)
        if model is None:
            raise ValueError(f"method {method!r} has no bake; one of {sorted(_BAKE_REQUESTS)}")
        r = create_bake.sync_detailed(
            client=self.client,
            body=model.from_dict(body),
            idempotency_key=idempotency_key or UNSET,
        )
        _raise(r)
        job = r.parsed
        if not wait or job.state.value in _TERMINAL:
            return job
        return self.wait(job.id, progress)

    def bake_artifact(self, job_id: str) -> bytes:
        r = get_bake_artifact.sync_detailed(job_id, client=self.client)
        _raise(r)
        return r.content

    def cancel_bake(self, job_id: str) -> Job:
        r = cancel_bake.sync_detailed(job_id, client=self.client)
        _raise(r)
        return r.parsed

    def bakes(self, state: str | None = None, method: str | None = None, created_since: int | None = None) -> Iterator[Job]:
        """Every bake the key holds, newest first (all pages), filtered as ``renders``."""
        return self._pages(list_bakes, _filters(ListBakesState, ListBakesMethod, state, method, created_since))

    # Jobs

    def job(self, job_id: str) -> Job:
        op = get_bake if job_id.startswith("bk_") else get_render
        r = op.sync_detailed(job_id, client=self.client)
        _raise(r)
        return r.parsed

    def events(self, job_id: str) -> Iterator[tuple[str, dict[str, Any]]]:
        """The job's server-sent events as (event, data) until the stream ends: ``progress``
        events, then one ``done`` (the whole job) or ``gone``."""
        kind = "bakes" if job_id.startswith("bk_") else "renders"
        with self._http().stream("GET", f"/v1/{kind}/{job_id}/events", timeout=None) as r:
            if r.status_code != 200:
                r.read()
                _raise(r)
            event, data = "message", []
            for line in r.iter_lines():
                if line == "":
                    if data:
                        yield event, json.loads("\n".join(data))
                    event, data = "message", []
                elif line.startswith(":"):
                    continue
                elif line.startswith("event:"):
                    event = line[6:].strip()
                elif line.startswith("data:"):
                    data.append(line[5:].lstrip())

    def wait(self, job_id: str, progress: Callable[[dict[str, Any]], None] | None = None) -> Job:
        """The job once finished, following its events (polling if the stream breaks)."""
        try:
            for event, data in self.events(job_id):
                if event == "progress" and progress:
                    progress(data)
                elif event == "done":
                    return Job.from_dict(data)
                elif event == "gone":
                    raise CausticaError(404, {"title": "Not found", "detail": f"job {job_id} was deleted"})
        except httpx.TransportError:
            pass
        while True:
            job = self.job(job_id)
            if job.state.value in _TERMINAL:
                return job
            time.sleep(1.0)

    def _pages(self, op, filters) -> Iterator[Any]:
        token = UNSET
        while True:
            r = op.sync_detailed(client=self.client, page_token=token, **filters)
            _raise(r)
            yield from r.parsed.items
            if not r.parsed.next_page_token:
                return
            token = r.parsed.next_page_token


def _filters(state_type, method_type, state, method, created_since) -> dict[str, Any]:
    """A list operation's filters as the generated enums."""
    f: dict[str, Any] = {}
    if state is not None:
        f["state"] = state_type(state)
    if method is not None:
        f["method"] = method_type(method)
    if created_since is not None:
        f["created_since"] = created_since
    return f
