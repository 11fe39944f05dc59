// The screen-space outline of a convex body given by six corners (a transport illumination
// volume, a caustic beam): the convex hull of the corners projected, grown by `margin` pixels,
// drawn as a fan of at most four triangles (HULL_VERTICES vertices; those past the polygon
// degenerate). Every pixel whose centre ray meets the body is covered exactly once. The polygon
// can be made once per body (hull_polygon, e.g. in a compute pass) and its fan's vertices
// read from it (hull_fan_vertex), or both per vertex (hull_outline).

// Vertices drawn per body.
const HULL_VERTICES: u32 = 12u;

// Clip-space w of the plane just in front of the eye that bodies crossing behind it are cut at.
const NEAR_W: f32 = 1e-4;

fn hull_cross(a: vec2<f32>, b: vec2<f32>) -> f32 {
    return a.x * b.y - a.y * b.x;
}

// An outline: `n` points (0 when nothing is drawn, else 3 to 6) counter-clockwise, in pixels
// (y up, like NDC).
struct HullPolygon {
    p: array<vec2<f32>, 6>,
    n: u32,
}

// Clip-space position of vertex `vi` of the outline of `corners` (world space) seen through
// `view_proj` on a target of `viewport` pixels.
fn hull_outline(corners: array<vec3<f32>, 6>, vi: u32, margin: f32, view_proj: mat4x4<f32>, viewport: vec2<f32>) -> vec4<f32> {
    return hull_fan_vertex(hull_polygon(corners, margin, view_proj, viewport), vi, viewport);
}

// Clip-space position of vertex `vi` of the fan of `poly` on a target of `viewport` pixels:
// fan triangle t = vi / 3 uses (0, t + 1, t + 2); triangles past the polygon are degenerate.
fn hull_fan_vertex(poly: HullPolygon, vi: u32, viewport: vec2<f32>) -> vec4<f32> {
    if vi / 3u + 2u >= poly.n {
        return vec4<f32>(0.0, 0.0, 0.0, 0.0);
    }
    return vec4<f32>(poly.p[fan_index(vi)] / (0.5 * viewport) - 1.0, 0.0, 1.0);
}

// The polygon point of fan vertex `vi`.
fn fan_index(vi: u32) -> u32 {
    let t = vi / 3u;
    let corner = vi % 3u;
    var idx = 0u;
    if corner == 1u {
        idx = t + 1u;
    } else if corner == 2u {
        idx = t + 2u;
    }
    return idx;
}

// The outline of `corners` (world space) seen through `view_proj` on a target of `viewport`
// pixels, grown by `margin` pixels.
fn hull_polygon(corners: array<vec3<f32>, 6>, margin: f32, view_proj: mat4x4<f32>, viewport: vec2<f32>) -> HullPolygon {
    var out: HullPolygon;
    out.n = 0u;
    // Pixel coordinates of the corners (y up, like NDC).
    var pts: array<vec2<f32>, 6>;
    var clip: array<vec4<f32>, 6>;
    var behind = false;
    let half = 0.5 * viewport;
    for (var k = 0u; k < 6u; k++) {
        let c = view_proj * vec4<f32>(corners[k], 1.0);
        clip[k] = c;
        if c.w <= NEAR_W {
            behind = true;
        } else {
            pts[k] = (c.xy / c.w + 1.0) * half;
        }
    }
    if behind {
        // Corners behind the eye: the body (the convex hull of its corners) cut by the plane
        // just in front of it has as vertices the corners in front and the points where the
        // edges between a corner in front and one behind cross that plane; drawn as the
        // rectangle around them projected (two triangles, the rest degenerate), nothing when
        // no corner is in front.
        var lo = vec2<f32>(3.0e38);
        var hi = vec2<f32>(-3.0e38);
        for (var i = 0u; i < 6u; i++) {
            if clip[i].w <= NEAR_W {
                continue;
            }
            lo = min(lo, pts[i]);
            hi = max(hi, pts[i]);
            for (var j = 0u; j < 6u; j++) {
                if clip[j].w > NEAR_W {
                    continue;
                }
                let f = (clip[i].w - NEAR_W) / (clip[i].w - clip[j].w);
                let c = mix(clip[i], clip[j], f);
                let q = (c.xy / NEAR_W + 1.0) * half;
                lo = min(lo, q);
                hi = max(hi, q);
            }
        }
        if lo.x > hi.x {
            return out;
        }
        lo = max(lo - vec2<f32>(margin), vec2<f32>(-1.0));
        hi = min(hi + vec2<f32>(margin), viewport + vec2<f32>(1.0));
        out.p[0] = lo;
        out.p[1] = vec2<f32>(hi.x, lo.y);
        out.p[2] = hi;
        out.p[3] = vec2<f32>(lo.x, hi.y);
        out.n = 4u;
        return out;
    }
    // Sort by x, then y (insertion sort of six), then Andrew's monotone chain.
    for (var i = 1u; i < 6u; i++) {
        let key = pts[i];
        var j = i;
        while j > 0u && (pts[j - 1u].x > key.x || (pts[j - 1u].x == key.x && pts[j - 1u].y > key.y)) {
            pts[j] = pts[j - 1u];
            j -= 1u;
        }
        pts[j] = key;
    }
    var hull: array<vec2<f32>, 12>;
    var n = 0u;
    for (var i = 0u; i < 6u; i++) {
        while n >= 2u && hull_cross(hull[n - 1u] - hull[n - 2u], pts[i] - hull[n - 2u]) <= 0.0 {
            n -= 1u;
        }
        hull[n] = pts[i];
        n += 1u;
    }
    let lower = n + 1u;
    for (var i = 4; i >= 0; i--) {
        let p = pts[u32(i)];
        while n >= lower && hull_cross(hull[n - 1u] - hull[n - 2u], p - hull[n - 2u]) <= 0.0 {
            n -= 1u;
        }
        hull[n] = p;
        n += 1u;
    }
    n -= 1u; // the last point repeats the first
    // Grow the polygon by `margin` pixels: each vertex moves along its miter, at most 8 margins.
    var grown: array<vec2<f32>, 6>;
    if n < 3u {
        // Degenerate (all corners on a line or a point): a square around the points.
        var lo = pts[0];
        var hi = pts[0];
        for (var k = 1u; k < 6u; k++) {
            lo = min(lo, pts[k]);
            hi = max(hi, pts[k]);
        }
        lo -= vec2<f32>(margin);
        hi += vec2<f32>(margin);
        grown[0] = lo;
        grown[1] = vec2<f32>(hi.x, lo.y);
        grown[2] = hi;
        grown[3] = vec2<f32>(lo.x, hi.y);
        n = 4u;
    } else {
        for (var k = 0u; k < n; k++) {
            let prev = hull[(k + n - 1u) % n];
            let cur = hull[k];
            let next = hull[(k + 1u) % n];
            let e1 = normalize(cur - prev);
            let e2 = normalize(next - cur);
            // Outward normals of a counter-clockwise polygon.
            let n1 = vec2<f32>(e1.y, -e1.x);
            let n2 = vec2<f32>(e2.y, -e2.x);
            let m = n1 + n2;
            let ml = length(m);
            var off = n1 * margin;
            if ml > 1e-6 {
                let c = max(dot(n1, m / ml), 1.0 / 8.0);
                off = (m / ml) * (margin / c);
            }
            grown[k] = cur + off;
        }
    }
    out.p = grown;
    out.n = n;
    return out;
}
