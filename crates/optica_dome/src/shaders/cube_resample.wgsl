// cube.rs: the domemaster resampled from the cube's face images, one
// direction per output pixel (the inverse of the dome's lens,
// `DomeProjection::unproject` on the CPU, or of the equirectangular
// panorama, `EquirectProjection::unproject`).
#import bevy_core_pipeline::fullscreen_vertex_shader::FullscreenVertexOutput
#import optica_dome::projection::{Lens, lens_theta, PI}

struct CubeParams {
    // Dome coordinates (image right, image up, along the axis) → cube frame.
    cube_from_dome: mat3x3<f32>,
    // Per face: looking along (xyz), 1 when the face is drawn (w).
    forward: array<vec4<f32>, 6>,
    // Per face: image up.
    up: array<vec4<f32>, 6>,
    theta_max: f32,
    // tan of half a face camera's field of view (one guard texel wider
    // than the cube's quarter).
    tan_half: f32,
    // NDC per image-circle radius along x and y.
    scale: vec2<f32>,
    // A polynomial lens's shape, (k₂, k₃, k₄)/k₁.
    shape: vec3<f32>,
    // The lens's number.
    lens: u32,
}

@group(0) @binding(0) var face0: texture_2d<f32>;
@group(0) @binding(1) var face1: texture_2d<f32>;
@group(0) @binding(2) var face2: texture_2d<f32>;
@group(0) @binding(3) var face3: texture_2d<f32>;
@group(0) @binding(4) var face4: texture_2d<f32>;
@group(0) @binding(5) var face5: texture_2d<f32>;
@group(0) @binding(6) var face_sampler: sampler;
@group(0) @binding(7) var<uniform> params: CubeParams;

fn sample_face(face: u32, uv: vec2<f32>) -> vec4<f32> {
    switch face {
        case 0u: { return textureSampleLevel(face0, face_sampler, uv, 0.0); }
        case 1u: { return textureSampleLevel(face1, face_sampler, uv, 0.0); }
        case 2u: { return textureSampleLevel(face2, face_sampler, uv, 0.0); }
        case 3u: { return textureSampleLevel(face3, face_sampler, uv, 0.0); }
        case 4u: { return textureSampleLevel(face4, face_sampler, uv, 0.0); }
        default: { return textureSampleLevel(face5, face_sampler, uv, 0.0); }
    }
}

@fragment
fn fragment(in: FullscreenVertexOutput) -> @location(0) vec4<f32> {
    var q: vec3<f32>;
    if params.lens == 5u {
        // The equirectangular panorama (E1 of the CPU twin): longitude
        // across, latitude up, filling the target.
        let lon = (in.uv.x * 2.0 - 1.0) * PI;
        let lat = (0.5 - in.uv.y) * PI;
        q = vec3<f32>(cos(lat) * sin(lon), sin(lat), cos(lat) * cos(lon));
    } else {
        // The pixel centre in units of the image circle's radius, y up.
        let ndc = vec2<f32>(in.uv.x * 2.0 - 1.0, 1.0 - in.uv.y * 2.0) / params.scale;
        let r = length(ndc);
        // Pixels outside the circle repeat the rim (the rim mask paints
        // them), so that no direction beyond the field of view is looked up.
        let lens = Lens(i32(params.lens), params.shape, params.theta_max);
        let theta = lens_theta(lens, r);
        var azimuth = vec2<f32>(0.0);
        if r > 0.0 {
            azimuth = ndc / r;
        }
        q = vec3<f32>(sin(theta) * azimuth, cos(theta));
    }
    let d = params.cube_from_dome * q;
    // The drawn face the direction is most nearly along: for the cube's
    // own faces that is the face containing it; among drawn faces only, a
    // tie on an edge never picks an undrawn one.
    var best = 0u;
    var best_dot = -2.0;
    for (var k = 0u; k < 6u; k++) {
        let f = params.forward[k];
        let along = dot(d, f.xyz);
        if f.w > 0.5 && along > best_dot {
            best = k;
            best_dot = along;
        }
    }
    let forward = params.forward[best].xyz;
    let up = params.up[best].xyz;
    let right = cross(forward, up);
    let z = max(best_dot, 1.0e-6) * params.tan_half;
    let uv = vec2<f32>(0.5 + 0.5 * dot(d, right) / z, 0.5 - 0.5 * dot(d, up) / z);
    return sample_face(best, uv);
}
