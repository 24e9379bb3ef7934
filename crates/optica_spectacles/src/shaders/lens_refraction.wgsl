// The lens's refraction of the view (the paper's §3.1, Fig. 1), with the
// eye camera's own view as the environment map:
//
// `march`: per lens vertex and colour (the exit rays of the C, d and F
// lines, for red, green and blue: the lens's chromatic aberration), (a)
// the exit ray's hit on the scene, found in the view's depth; (b–d) that
// point projected into the view gives the vertex's texture coordinate for
// that colour (`coords`: green's for every vertex, then red's, then blue's). A ray that meets nothing (the sky, or it
// leaves the view first) takes its direction's point at infinity.
//
// `copy_*` draws the view unchanged; `lens_*` then draws the lens's back
// surface over it, each fragment showing the view at the coordinate
// interpolated from its triangle's vertices; vertices whose ray does not
// get through (total reflection, the rim) mask their triangles as the
// lens's dark edge. `MULTISAMPLED` reads sample 0 of an MSAA depth.

#import bevy_core_pipeline::fullscreen_vertex_shader::FullscreenVertexOutput

struct LensVertex {
    back: vec3<f32>,
    exits: u32,
    origin: vec3<f32>,
    _pad0: f32,
    dir: vec3<f32>,
    _pad1: f32,
    dir_red: vec3<f32>,
    _pad2: f32,
    dir_blue: vec3<f32>,
    _pad3: f32,
}

struct LensParams {
    clip_from_view: mat4x4<f32>,
    // Reverse-Z infinite perspective: depth = near / distance.
    near: f32,
    vertices: u32,
    steps: u32,
    // The lens's dark edge, linear RGB.
    edge: f32,
    // 3 when the lens parts the colours, else 1 (green's coordinate
    // stands for all three and red's and blue's are not marched).
    colours: u32,
}

@group(0) @binding(0) var<uniform> params: LensParams;
@group(0) @binding(1) var<storage, read> lens: array<LensVertex>;
#ifdef MARCH
@group(0) @binding(2) var<storage, read_write> coords: array<vec4<f32>>;
#ifdef MULTISAMPLED
@group(0) @binding(3) var depth: texture_depth_multisampled_2d;
#else
@group(0) @binding(3) var depth: texture_depth_2d;
#endif
#else
@group(0) @binding(2) var<storage, read> coords: array<vec4<f32>>;
@group(0) @binding(3) var view: texture_2d<f32>;
@group(0) @binding(4) var view_sampler: sampler;
#endif

// View-space point to texture coordinate (0..1, y down) and its w.
fn project(p: vec4<f32>) -> vec3<f32> {
    let c = params.clip_from_view * p;
    let ndc = c.xy / c.w;
    return vec3<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5, c.w);
}

#ifdef MARCH
// The scene's distance (view depth, m) at texture coordinate `uv`, or a
// negative number off the view.
fn scene_distance(uv: vec2<f32>) -> f32 {
    let size = vec2<f32>(textureDimensions(depth));
    if any(uv < vec2<f32>(0.0)) || any(uv >= vec2<f32>(1.0)) {
        return -1.0;
    }
    let d = textureLoad(depth, vec2<i32>(uv * size), 0);
    if d <= 0.0 {
        return 1e30;
    }
    return params.near / d;
}

// The scene's distance under the ray's point at `t` (negative off the view).
fn scene_under(o: vec3<f32>, d: vec3<f32>, t: f32) -> f32 {
    return scene_distance(project(vec4<f32>(o + d * t, 1.0)).xy);
}

// Whether the ray's point at `t` lies behind the visible surface. Scene
// nearer than the ray's origin is not on its path (for a mirror: what lies
// behind it, between the virtual viewpoint and its surface).
fn behind(o: vec3<f32>, d: vec3<f32>, t: f32) -> bool {
    let scene = scene_under(o, d, t);
    return scene > -o.z && -(o.z + d.z * t) >= scene;
}

@compute @workgroup_size(64)
fn march(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x % params.vertices;
    let colour = id.x / params.vertices;
    if colour >= params.colours {
        return;
    }
    var v = lens[i];
    if colour == 1u {
        v.dir = v.dir_red;
    } else if colour == 2u {
        v.dir = v.dir_blue;
    }
    // Geometric steps from 2 cm to 2 km past the lens, then bisection.
    let t0 = 0.02;
    let ratio = pow(1e5, 1.0 / f32(params.steps));
    var lo = 0.0;
    var hi = -1.0;
    var t = t0;
    // The scene's distance at the last point of the ray inside the view.
    var last_seen = -1.0;
    for (var k = 0u; k < params.steps; k++) {
        let scene = scene_under(v.origin, v.dir, t);
        if scene > -v.origin.z && -(v.origin.z + v.dir.z * t) >= scene {
            hi = t;
            break;
        }
        if scene > -v.origin.z {
            last_seen = scene;
        }
        lo = t;
        t *= ratio;
    }
    var uv: vec2<f32>;
    var hit = 0.0;
    if hi > 0.0 {
        for (var k = 0u; k < 16u; k++) {
            let mid = 0.5 * (lo + hi);
            if behind(v.origin, v.dir, mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        uv = project(vec4<f32>(v.origin + v.dir * hi, 1.0)).xy;
        hit = 1.0;
    } else if last_seen > 0.0 && last_seen < 1e29 && v.dir.z < 0.0 {
        // The ray left the view before it met the scene (a minus lens
        // shows past the view's edge): the scene is taken to go on at the
        // distance it had where the ray left.
        let t_hit = (last_seen + v.origin.z) / -v.dir.z;
        uv = project(vec4<f32>(v.origin + v.dir * t_hit, 1.0)).xy;
    } else {
        // Nothing met: the direction's point at infinity.
        uv = project(vec4<f32>(v.dir, 0.0)).xy;
    }
    coords[id.x] = vec4<f32>(uv, hit, f32(v.exits));
}
#else

@fragment
fn copy_fragment(in: FullscreenVertexOutput) -> @location(0) vec4<f32> {
    return textureSampleLevel(view, view_sampler, in.uv, 0.0);
}

struct LensOut {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) exits: f32,
    @location(2) uv_red: vec2<f32>,
    @location(3) uv_blue: vec2<f32>,
}

@vertex
fn lens_vertex(@builtin(vertex_index) i: u32) -> LensOut {
    var out: LensOut;
    var c = params.clip_from_view * vec4<f32>(lens[i].back, 1.0);
    // No depth test: any depth inside the clip volume.
    c.z = 0.5 * c.w;
    out.position = c;
    out.uv = coords[i].xy;
    out.exits = coords[i].w;
    let parted = params.colours == 3u;
    out.uv_red = coords[select(i, params.vertices + i, parted)].xy;
    out.uv_blue = coords[select(i, 2u * params.vertices + i, parted)].xy;
    return out;
}

@fragment
fn lens_fragment(in: LensOut) -> @location(0) vec4<f32> {
    let lo = vec2<f32>(0.0);
    let hi = vec2<f32>(1.0);
    let seen = vec3<f32>(
        textureSampleLevel(view, view_sampler, clamp(in.uv_red, lo, hi), 0.0).r,
        textureSampleLevel(view, view_sampler, clamp(in.uv, lo, hi), 0.0).g,
        textureSampleLevel(view, view_sampler, clamp(in.uv_blue, lo, hi), 0.0).b,
    );
    // A triangle with a vertex whose ray does not get through: the edge.
    let through = step(0.999, in.exits);
    return vec4<f32>(mix(vec3<f32>(params.edge), seen, through), 1.0);
}
#endif
