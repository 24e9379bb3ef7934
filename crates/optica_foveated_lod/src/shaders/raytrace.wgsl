// The paper's ray tracer on the GPU (Mochizuki and Makino, §3.3.3): a
// Whitted tracer (reflection and refraction) with a level per ray. The
// twin of `optica_optics::foveated_lod::{VisualField::level,
// LevelQuantization::apply, reflect_limit, lod_for_level, trace_ray}`.
//
// Each primary ray's level (eq. 1–8 from the gaze frame, quantised into
// `steps`) sets how many bounces it may make (eq. 9) and which mesh of each
// object it and its secondary rays are tested against (eq. 10); a level-0
// ray returns the background without being traced (Step 2).
//
// The periphery is traced on nested coarser grids, as Guenter et al.'s
// foveated layers (2012): `trace_mid`, a grid `scale` times coarser than the
// image, traces its texels of level in [outer_level, 1); `trace_outer`, a
// grid 2·scale times coarser, every texel of level below 1 (only when
// outer_level > 0). Texels not traced are marked with alpha 0.
// `trace_full`: every pixel of the central field (or every pixel, when
// `full_quality` or `scale` is 1) is traced; a peripheral pixel takes the
// bilinear blend of its layer (mid at level ≥ outer_level, else outer),
// or of the other layer where a tap of its own was not traced, or is
// traced itself where neither has all four taps. `blit_*` copies the result
// into the view.

#import bevy_core_pipeline::fullscreen_vertex_shader::FullscreenVertexOutput

struct Params {
    // The camera's rotation times its clip-to-view matrix (no translation).
    world_from_clip: mat4x4<f32>,
    eye: vec3<f32>,
    width: u32,
    gaze_forward: vec3<f32>,
    height: u32,
    gaze_right: vec3<f32>,
    low_width: u32,
    gaze_up: vec3<f32>,
    low_height: u32,
    background: vec3<f32>,
    scale: u32,
    ambient: vec3<f32>,
    reflect_max: u32,
    central: f32,
    ear: f32,
    nose: f32,
    upper: f32,
    lower: f32,
    // 0: the paper's cyclopean field, 1: left eye, 2: right eye.
    eye_model: u32,
    // 0: eq. 7 as printed, 1: a true ellipse.
    boundary: u32,
    // Level steps S (0: continuous).
    steps: u32,
    full_quality: u32,
    object_count: u32,
    light_count: u32,
    // Levels below it use the outer layer (0: no outer layer).
    outer_level: f32,
    // The view's viewport in its target (px).
    origin: vec2<u32>,
    outer_width: u32,
    outer_height: u32,
}

struct Node {
    min: vec3<f32>,
    // Left child, or LEAF_BIT | first triangle.
    a: u32,
    max: vec3<f32>,
    // Right child, or triangle count.
    b: u32,
}

struct Vertex {
    position: vec3<f32>,
    normal: vec3<f32>,
}

struct Mesh {
    root: u32,
    triangles: u32,
}

struct Object {
    min: vec3<f32>,
    first_mesh: u32,
    max: vec3<f32>,
    mesh_count: u32,
    color: vec3<f32>,
    diffuse: f32,
    specular: f32,
    shininess: f32,
    reflectance: f32,
    transmittance: f32,
    ior: f32,
}

struct Light {
    position: vec3<f32>,
    intensity: vec3<f32>,
}

@group(0) @binding(0) var<uniform> params: Params;
#ifdef TRACE
@group(0) @binding(1) var<storage, read> nodes: array<Node>;
@group(0) @binding(2) var<storage, read> triangles: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read> vertices: array<Vertex>;
@group(0) @binding(4) var<storage, read> meshes: array<Mesh>;
@group(0) @binding(5) var<storage, read> objects: array<Object>;
@group(0) @binding(6) var<storage, read> lights: array<Light>;
@group(0) @binding(7) var<storage, read_write> image: array<vec4<f32>>;
// The middle layer's texels, then the outer layer's (eight storage buffers
// per stage is WebGPU's default limit).
@group(0) @binding(8) var<storage, read_write> low: array<vec4<f32>>;
#else
@group(0) @binding(1) var<storage, read> image: array<vec4<f32>>;
#endif

const LEAF_BIT: u32 = 0x80000000u;
// Slack of the level arithmetic, as `ROUND_SLACK` in the twin (1e-9 there,
// in f64); f32 rounds a product like (2/3)·3 to within a few 1e-7.
const ROUND_SLACK: f32 = 1e-5;
// Secondary ray origins leave the surface by this much, relative to the
// hit point's largest coordinate (plus 1 m): f32's hit points are good to a
// few 1e-7 relative, so 3e-5 never re-hits the surface through rounding
// (the twin's 1e-7 is for f64), and stays 0.1 mm at 3 m.
const OFFSET_REL: f32 = 3e-5;
// Nearest accepted hit distance (m).
const T_MIN: f32 = 1e-6;
// BVH stack depth: the binned-SAH trees of meshes of up to millions of
// triangles stay well below it.
const STACK: u32 = 40u;
// Pending rays of the Whitted tree: at most reflect_max + 1 (≤ 8) wait at
// once in a depth-first walk that pushes two children per hit.
const PENDING: u32 = 8u;
// Invocations per workgroup of the tracing passes (a warp on NVIDIA). The
// BVH stacks live in workgroup memory, a slice per invocation (10 KiB in
// all, within WebGPU's 16 KiB): as function-local arrays, zeroed at every
// invocation's start, the full-quality frame took a fifth longer on
// llvmpipe.
const LANES: u32 = 32u;

#ifdef TRACE
// This invocation's slice of the workgroup's stacks (`slot`).
var<private> lane: u32;
var<workgroup> stack_node: array<u32, 1280>; // STACK · LANES
var<workgroup> stack_t: array<f32, 1280>;
// ---- eq. 1–8 and the quantisation --------------------------------------

// The level of a world direction from the eye (`VisualField::level` then
// `LevelQuantization::apply`).
fn field_level(d: vec3<f32>) -> f32 {
    if params.full_quality != 0u {
        return 1.0;
    }
    let df = dot(d, params.gaze_forward);
    let dr = dot(d, params.gaze_right);
    let du = dot(d, params.gaze_up);
    var ma = atan2(dr, df);
    if params.eye_model == 0u {
        ma = atan2(abs(dr), df);
    }
    let mb = atan2(du, abs(df));
    let l2 = ma * ma + mb * mb;
    let l = sqrt(l2);
    var level = 1.0;
    if l > params.central {
        var a = params.nose;
        if params.eye_model == 0u || (params.eye_model == 2u && ma >= 0.0)
            || (params.eye_model == 1u && ma <= 0.0) {
            a = params.ear;
        }
        var b = params.lower;
        if mb >= 0.0 {
            b = params.upper;
        }
        var big_l: f32;
        if params.boundary == 0u {
            big_l = sqrt((a * a * ma * ma + b * b * mb * mb) / l2);
        } else {
            big_l = a * b * l / sqrt(b * b * ma * ma + a * a * mb * mb);
        }
        if l > big_l {
            level = 0.0;
        } else {
            level = clamp((big_l - l) / (big_l - params.central), 0.0, 1.0);
        }
    }
    if params.steps == 0u {
        return level;
    }
    let s = f32(params.steps);
    return min(floor(level * s + ROUND_SLACK), s) / s;
}

// Eq. 9: ⌊level × Reflect_max⌋.
fn reflect_limit(level: f32) -> u32 {
    return min(u32(floor(level * f32(params.reflect_max) + ROUND_SLACK)), params.reflect_max);
}

// Eq. 10 then the coarsest mesh with at least that many triangles.
fn lod_for_level(o: Object, level: f32) -> u32 {
    let lo = f32(meshes[o.first_mesh].triangles);
    let hi = f32(meshes[o.first_mesh + o.mesh_count - 1u].triangles);
    let need = level * (hi - lo) + lo - 1e-3;
    for (var k = 0u; k < o.mesh_count; k++) {
        if f32(meshes[o.first_mesh + k].triangles) >= need {
            return k;
        }
    }
    return o.mesh_count - 1u;
}

// ---- intersection ---------------------------------------------------------

// Slab test: the entry distance into the box within [0, t_max], or -1.
fn box_entry(lo: vec3<f32>, hi: vec3<f32>, o: vec3<f32>, inv: vec3<f32>, t_max: f32) -> f32 {
    let t1 = (lo - o) * inv;
    let t2 = (hi - o) * inv;
    let near = max(max(min(t1.x, t2.x), min(t1.y, t2.y)), max(min(t1.z, t2.z), 0.0));
    let far = min(min(max(t1.x, t2.x), max(t1.y, t2.y)), min(max(t1.z, t2.z), t_max));
    if near <= far {
        return near;
    }
    return -1.0;
}

struct Hit {
    t: f32,
    object: u32,
    triangle: u32,
    u: f32,
    v: f32,
}

// Möller–Trumbore: (t, u, v) with T_MIN < t < t_max, or t = -1.
fn triangle_hit(tri: u32, o: vec3<f32>, d: vec3<f32>, t_max: f32) -> vec3<f32> {
    let idx = triangles[tri];
    let a = vertices[idx.x].position;
    let e1 = vertices[idx.y].position - a;
    let e2 = vertices[idx.z].position - a;
    let p = cross(d, e2);
    let det = dot(e1, p);
    if abs(det) <= 1e-7 * length(e1) * length(e2) {
        return vec3(-1.0, 0.0, 0.0);
    }
    let inv = 1.0 / det;
    let s = o - a;
    let u = dot(s, p) * inv;
    if u < 0.0 || u > 1.0 {
        return vec3(-1.0, 0.0, 0.0);
    }
    let q = cross(s, e1);
    let v = dot(d, q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return vec3(-1.0, 0.0, 0.0);
    }
    let t = dot(e2, q) * inv;
    if t > T_MIN && t < t_max {
        return vec3(t, u, v);
    }
    return vec3(-1.0, 0.0, 0.0);
}

// Entry `i` of this invocation's stack, interleaved so that neighbouring
// invocations touch neighbouring words.
fn slot(i: u32) -> u32 {
    return i * LANES + lane;
}

// The closest hit in one mesh's BVH, near child first (as `Bvh::closest`);
// `best` is improved in place.
fn mesh_closest(root: u32, object: u32, o: vec3<f32>, d: vec3<f32>, inv: vec3<f32>, best: ptr<function, Hit>) {
    var sp = 0u;
    let r = nodes[root];
    let t0 = box_entry(r.min, r.max, o, inv, (*best).t);
    if t0 < 0.0 {
        return;
    }
    stack_node[slot(0)] = root;
    stack_t[slot(0)] = t0;
    sp = 1u;
    while sp > 0u {
        sp -= 1u;
        if stack_t[slot(sp)] > (*best).t {
            continue;
        }
        let n = nodes[stack_node[slot(sp)]];
        if (n.a & LEAF_BIT) != 0u {
            let first = n.a & ~LEAF_BIT;
            for (var k = first; k < first + n.b; k++) {
                let h = triangle_hit(k, o, d, (*best).t);
                if h.x > 0.0 {
                    *best = Hit(h.x, object, k, h.y, h.z);
                }
            }
            continue;
        }
        let left = nodes[n.a];
        let right = nodes[n.b];
        let tl = box_entry(left.min, left.max, o, inv, (*best).t);
        let tr = box_entry(right.min, right.max, o, inv, (*best).t);
        // Far child first, so that the near one pops first.
        if tl >= 0.0 && tr >= 0.0 && sp + 2u <= STACK {
            if tl <= tr {
                stack_node[slot(sp)] = n.b; stack_t[slot(sp)] = tr;
                stack_node[slot(sp + 1u)] = n.a; stack_t[slot(sp + 1u)] = tl;
            } else {
                stack_node[slot(sp)] = n.a; stack_t[slot(sp)] = tl;
                stack_node[slot(sp + 1u)] = n.b; stack_t[slot(sp + 1u)] = tr;
            }
            sp += 2u;
        } else if tl >= 0.0 && sp < STACK {
            stack_node[slot(sp)] = n.a; stack_t[slot(sp)] = tl;
            sp += 1u;
        } else if tr >= 0.0 && sp < STACK {
            stack_node[slot(sp)] = n.b; stack_t[slot(sp)] = tr;
            sp += 1u;
        }
    }
}

// True when a triangle of the mesh blocks the ray before t_max.
fn mesh_any(root: u32, o: vec3<f32>, d: vec3<f32>, inv: vec3<f32>, t_max: f32) -> bool {
    var sp = 1u;
    stack_node[slot(0)] = root;
    while sp > 0u {
        sp -= 1u;
        let n = nodes[stack_node[slot(sp)]];
        if box_entry(n.min, n.max, o, inv, t_max) < 0.0 {
            continue;
        }
        if (n.a & LEAF_BIT) != 0u {
            let first = n.a & ~LEAF_BIT;
            for (var k = first; k < first + n.b; k++) {
                if triangle_hit(k, o, d, t_max).x > 0.0 {
                    return true;
                }
            }
        } else if sp + 2u <= STACK {
            stack_node[slot(sp)] = n.a;
            stack_node[slot(sp + 1u)] = n.b;
            sp += 2u;
        }
    }
    return false;
}

// 1/d, a zero component made tiny rather than infinite: the slab test's
// (plane − origin)·∞ would be NaN for an origin on a box face.
fn inverse_dir(d: vec3<f32>) -> vec3<f32> {
    return 1.0 / select(d, vec3(1e-30), d == vec3(0.0));
}

// The closest hit in the scene, every object at its mesh of eq. 10.
fn scene_closest(o: vec3<f32>, d: vec3<f32>, level: f32) -> Hit {
    var best = Hit(3.4e38, 0xffffffffu, 0u, 0.0, 0.0);
    let inv = inverse_dir(d);
    for (var i = 0u; i < params.object_count; i++) {
        let ob = objects[i];
        if box_entry(ob.min, ob.max, o, inv, best.t) < 0.0 {
            continue;
        }
        let mesh = meshes[ob.first_mesh + lod_for_level(ob, level)];
        mesh_closest(mesh.root, i, o, d, inv, &best);
    }
    return best;
}

fn scene_occluded(o: vec3<f32>, d: vec3<f32>, level: f32, t_max: f32) -> bool {
    let inv = inverse_dir(d);
    for (var i = 0u; i < params.object_count; i++) {
        let ob = objects[i];
        if box_entry(ob.min, ob.max, o, inv, t_max) < 0.0 {
            continue;
        }
        let mesh = meshes[ob.first_mesh + lod_for_level(ob, level)];
        if mesh_any(mesh.root, o, d, inv, t_max) {
            return true;
        }
    }
    return false;
}

// ---- shading (`trace_ray`) ------------------------------------------------

struct Pending {
    origin: vec3<f32>,
    depth: u32,
    dir: vec3<f32>,
    weight: vec3<f32>,
}

fn offset(p: vec3<f32>) -> f32 {
    let a = abs(p);
    return OFFSET_REL * (1.0 + max(a.x, max(a.y, a.z)));
}

// One primary ray at its level: the Whitted tree walked depth first, each
// ray's contribution weighted by the product of the shares above it.
fn trace_ray(origin: vec3<f32>, dir: vec3<f32>, level: f32) -> vec3<f32> {
    if level <= 0.0 {
        return params.background;
    }
    let limit = reflect_limit(level);
    var pending: array<Pending, PENDING>;
    pending[0] = Pending(origin, 0u, dir, vec3(1.0));
    var sp = 1u;
    var color = vec3(0.0);
    while sp > 0u {
        sp -= 1u;
        let ray = pending[sp];
        let d = ray.dir;
        let h = scene_closest(ray.origin, d, level);
        if h.object == 0xffffffffu {
            color += ray.weight * params.background;
            continue;
        }
        let ob = objects[h.object];
        let idx = triangles[h.triangle];
        let va = vertices[idx.x];
        let vb = vertices[idx.y];
        let vc = vertices[idx.z];
        let p = ray.origin + d * h.t;
        // Two-sided: both normals turned towards the incoming ray.
        let face = normalize(cross(vb.position - va.position, vc.position - va.position));
        var geo = face;
        if dot(geo, d) > 0.0 {
            geo = -geo;
        }
        let interp = va.normal * (1.0 - h.u - h.v) + vb.normal * h.u + vc.normal * h.v;
        var n = face;
        if dot(interp, interp) > 0.0 {
            n = normalize(interp);
        }
        if dot(n, geo) < 0.0 {
            n = -n;
        }
        let o = p + geo * offset(p);
        var local = params.ambient * ob.color;
        for (var li = 0u; li < params.light_count; li++) {
            let light = lights[li];
            let to_l = light.position - o;
            let dist = length(to_l);
            if !(dist > 0.0) {
                continue;
            }
            let l = to_l / dist;
            let ndl = dot(n, l);
            if ndl <= 0.0 {
                continue;
            }
            if scene_occluded(o, l, level, dist) {
                continue;
            }
            let irr = light.intensity / (dist * dist);
            let rs = max(dot(reflect(-l, n), -d), 0.0);
            var spec = 0.0;
            if rs > 0.0 {
                spec = pow(rs, ob.shininess);
            }
            local += irr * (ob.color * (ob.diffuse * ndl) + vec3(ob.specular * spec));
        }
        var kr = ob.reflectance;
        let kt = ob.transmittance;
        color += ray.weight * local * (1.0 - kr - kt);
        if ray.depth >= limit {
            continue;
        }
        if kt > 0.0 {
            let entering = dot(face, d) < 0.0;
            var eta = ob.ior;
            if entering {
                eta = 1.0 / ob.ior;
            }
            // WGSL's refract wants the normal against the ray; a smooth
            // normal at a silhouette can lean the other way (the twin flips it too).
            let t = refract(d, select(n, -n, dot(n, d) > 0.0), eta);
            if dot(t, t) == 0.0 {
                kr += kt; // total internal reflection
            } else if sp < PENDING {
                pending[sp] = Pending(p - geo * offset(p), ray.depth + 1u, normalize(t), ray.weight * kt);
                sp += 1u;
            }
        }
        if kr > 0.0 && sp < PENDING {
            pending[sp] = Pending(o, ray.depth + 1u, reflect(d, n), ray.weight * kr);
            sp += 1u;
        }
    }
    return color;
}

// ---- the passes -----------------------------------------------------------

// The primary ray through a point of the image (pixels, continuous, y down).
fn primary_dir(px: vec2<f32>) -> vec3<f32> {
    let size = vec2(f32(params.width), f32(params.height));
    let ndc = vec2(2.0 * px.x / size.x - 1.0, 1.0 - 2.0 * px.y / size.y);
    // Bevy's reverse z: the near plane is at z = 1. The matrix leaves the
    // camera's translation out, so the near-plane point is the direction
    // itself, exact far from the world's origin.
    let p = params.world_from_clip * vec4(ndc, 1.0, 1.0);
    return normalize(p.xyz / p.w);
}

// The ray of a coarse texel `id` of a grid `k` times coarser, and whether
// its level lies in [lo, 1): then it is traced (alpha 1), else marked (0).
fn trace_texel(id: vec2<u32>, k: f32, lo: f32) -> vec4<f32> {
    let d = primary_dir((vec2<f32>(id) + 0.5) * k);
    let level = field_level(d);
    if level < 1.0 && level >= lo {
        return vec4(trace_ray(params.eye, d, level), 1.0);
    }
    return vec4(0.0);
}

@compute @workgroup_size(8, 4, 1)
fn trace_mid(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    lane = li;
    if id.x >= params.low_width || id.y >= params.low_height {
        return;
    }
    low[id.y * params.low_width + id.x] = trace_texel(id.xy, f32(params.scale), params.outer_level);
}

fn outer_base() -> u32 {
    return params.low_width * params.low_height;
}

@compute @workgroup_size(8, 4, 1)
fn trace_outer(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    lane = li;
    if id.x >= params.outer_width || id.y >= params.outer_height {
        return;
    }
    low[outer_base() + id.y * params.outer_width + id.x] = trace_texel(id.xy, f32(2u * params.scale), 0.0);
}

// Bilinear taps of a grid `k` times coarser than the image, whose texel i is
// centred at (i + 0.5)·k: the four texel indices and the weights.
struct Taps {
    i00: u32,
    i10: u32,
    i01: u32,
    i11: u32,
    f: vec2<f32>,
}

fn taps(px: vec2<f32>, k: f32, size: vec2<u32>) -> Taps {
    let g = px / k - 0.5;
    let lo = clamp(floor(g), vec2(0.0), vec2<f32>(size - 1u));
    let f = clamp(g - lo, vec2(0.0), vec2(1.0));
    let i0 = vec2<u32>(lo);
    let i1 = min(i0 + 1u, size - 1u);
    return Taps(i0.y * size.x + i0.x, i0.y * size.x + i1.x, i1.y * size.x + i0.x, i1.y * size.x + i1.x, f);
}

fn blend(c00: vec4<f32>, c10: vec4<f32>, c01: vec4<f32>, c11: vec4<f32>, f: vec2<f32>) -> vec4<f32> {
    let a = min(min(c00.a, c10.a), min(c01.a, c11.a));
    let c = mix(mix(c00.rgb, c10.rgb, f.x), mix(c01.rgb, c11.rgb, f.x), f.y);
    return vec4(c, a);
}

fn sample_mid(px: vec2<f32>) -> vec4<f32> {
    let t = taps(px, f32(params.scale), vec2(params.low_width, params.low_height));
    return blend(low[t.i00], low[t.i10], low[t.i01], low[t.i11], t.f);
}

fn sample_outer(px: vec2<f32>) -> vec4<f32> {
    if params.outer_level <= 0.0 {
        return vec4(0.0);
    }
    let t = taps(px, f32(2u * params.scale), vec2(params.outer_width, params.outer_height));
    let o = outer_base();
    return blend(low[o + t.i00], low[o + t.i10], low[o + t.i01], low[o + t.i11], t.f);
}

@compute @workgroup_size(8, 4, 1)
fn trace_full(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    lane = li;
    if id.x >= params.width || id.y >= params.height {
        return;
    }
    let px = vec2<f32>(id.xy) + 0.5;
    let d = primary_dir(px);
    let level = field_level(d);
    var c = params.background;
    if level > 0.0 {
        var traced = true;
        if level < 1.0 && params.scale > 1u {
            var first = sample_mid(px);
            if level < params.outer_level {
                first = sample_outer(px);
            }
            if first.a == 1.0 {
                c = first.rgb;
                traced = false;
            } else {
                var second = sample_outer(px);
                if level < params.outer_level {
                    second = sample_mid(px);
                }
                if second.a == 1.0 {
                    c = second.rgb;
                    traced = false;
                }
            }
        }
        if traced {
            c = trace_ray(params.eye, d, level);
        }
    }
    image[id.y * params.width + id.x] = vec4(c, 1.0);
}
#else
@fragment
fn blit_fragment(in: FullscreenVertexOutput) -> @location(0) vec4<f32> {
    let p = vec2<u32>(in.position.xy) - params.origin;
    return image[p.y * params.width + p.x];
}
#endif
