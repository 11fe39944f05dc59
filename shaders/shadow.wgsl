// Shadow pass: renders the depth of every object (receivers and specular objects alike, both
// faces) into one layer of the shadow map array, as seen from a light: orthographic for
// directional lights, perspective for spots, one of six 90°+ faces for point lights and line
// light samples. Depth bias is applied by the pipeline (slope-scaled) and by a normal offset in
// the lighting pass. No fragment stage: depth only.

struct Layer {
    view_proj: mat4x4<f32>,
}

@group(0) @binding(0) var<uniform> layer: Layer;

@vertex
fn vs_main(@location(0) position: vec3<f32>) -> @builtin(position) vec4<f32> {
    return layer.view_proj * vec4<f32>(position, 1.0);
}
