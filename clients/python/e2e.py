"""End-to-end check of the Python client against a running server (the tests run it as
`python3 clients/python/e2e.py BASE_URL GLB SCENE_JSON` with PYTHONPATH=clients/python).

Uploads a GLB and a scene JSON, renders PNG and EXR, runs a csl bake to completion while
following its progress, cancels a bake, lists jobs, and checks a bad request raises the
server's problem. Prints one line per step; exits non-zero on the first failure.
"""

import json
import sys

from caustica import Caustica, CausticaError
from caustica_client.models import JobState, Method


def check(cond, what):
    if not cond:
        raise SystemExit(f"FAILED: {what}")
    print(f"ok: {what}", flush=True)


def main():
    base, glb, scene_json = sys.argv[1], sys.argv[2], sys.argv[3]
    c = Caustica(base)

    info = c.upload_scene(glb)
    check(len(info.id) == 64 and info.triangles > 0, f"GLB uploaded: {info.id[:12]}, {info.triangles} triangles")
    with open(scene_json) as f:
        scene = json.load(f)
    sphere = c.upload_scene(scene)
    glass = [o.name for o in sphere.objects if o.specular]
    check(glass, f"scene JSON uploaded with glass objects {glass}")

    png = c.render(info.id, method="direct", width=64, height=48)
    check(png[:8] == b"\x89PNG\r\n\x1a\n", f"PNG render of the GLB ({len(png)} bytes)")
    exr = c.render(sphere.id, method="direct", width=64, height=48, format="exr")
    check(exr[:4] == b"\x76\x2f\x31\x01", f"EXR render of the scene ({len(exr)} bytes)")

    seen = []
    job = c.bake(sphere.id, glass[0], "csl", params={"preset": "fast", "grid": 64}, progress=seen.append)
    check(job.state == JobState.SUCCEEDED, f"csl bake {job.id} succeeded")
    check(job.method == Method.CSL and job.artifact, "the finished bake names its artifact")
    art = c.bake_artifact(job.id)
    check(len(art) > 0, f"bake artifact downloaded ({len(art)} bytes, {len(seen)} progress events)")

    # A bake that takes a while, canceled: the reference at a size that runs for seconds.
    slow = c.bake(
        sphere.id, glass[0], "reference",
        params={"photons": 50_000_000, "spp": 64, "width": 256, "height": 256, "seed": 7},
        wait=False,
    )
    canceled = c.cancel_bake(slow.id)
    check(canceled.state in (JobState.CANCELED, JobState.SUCCEEDED), f"bake {slow.id} canceled ({canceled.state.value})")
    check(c.wait(slow.id).state == JobState.CANCELED, "the canceled bake stays canceled")

    bakes = list(c.bakes())
    check({job.id, slow.id} <= {b.id for b in bakes}, f"bakes listed ({len(bakes)})")
    canceled_only = list(c.bakes(state="canceled"))
    check([b.id for b in canceled_only] == [slow.id], "bakes filtered by state")
    renders = list(c.renders())
    check(len(renders) >= 2, f"renders listed ({len(renders)})")
    check(len(list(c.scenes())) >= 2, "scenes listed")

    try:
        c.render(sphere.id, method="direct", width=100000)
        check(False, "an impossible width is refused")
    except CausticaError as e:
        check(e.status == 422 and e.field == "width", f"an impossible width raises the problem: {e}")
    print("e2e: all passed")


if __name__ == "__main__":
    main()
