// The flare's occlusion pass: for each flaring light, the fraction of a
// fixed disk of depth samples round its image that lies behind the light,
// blended with the last frame's (`FlareOcclusion`). One workgroup a light;
// its 64 threads read 4 samples each and sum them.
// `MULTISAMPLED` reads sample 0 of an MSAA depth.
//
// Under TAA the depth buffer is drawn with a projection jittered by a
// subpixel each frame: the disk follows the jitter (`jitter_ndc`), and
// since the texels still sample the scene at other points each frame, the
// raw fractions of the last `jitter_cycle` frames (one whole jitter
// sequence, one slot per offset) are averaged before the history. A static
// scene's visibility is then the same every frame instead of flickering
// at an occluder's edge.
//
// `visibility` holds each light's visibility, then, per light,
// `jitter_cycle` raw fractions.

#import optica_lens_flare::types::{FlareParams, LightProbe}

@group(0) @binding(0) var<uniform> params: FlareParams;
@group(0) @binding(1) var<storage, read> lights: array<LightProbe>;
#ifdef MULTISAMPLED
@group(0) @binding(2) var depth: texture_depth_multisampled_2d;
#else
@group(0) @binding(2) var depth: texture_depth_2d;
#endif
@group(0) @binding(3) var<storage, read_write> visibility: array<f32>;

const SAMPLES: u32 = 256u;
const PER_THREAD: u32 = 4u;
// The golden angle: successive samples of the sunflower (Vogel) disk.
const GOLDEN_ANGLE: f32 = 2.39996323;

var<workgroup> partial: array<f32, 64>;

// 1 where sample `k` of the disk round `probe` is not hidden, else 0.
fn sample_visible(probe: LightProbe, k: u32, size: vec2<u32>) -> f32 {
    let r = params.occlusion_radius_px * sqrt((f32(k) + 0.5) / f32(SAMPLES));
    let a = f32(k) * GOLDEN_ANGLE;
    let ndc = probe.ndc + params.jitter_ndc;
    let centre = (vec2<f32>(ndc.x, -ndc.y) * 0.5 + 0.5) * vec2<f32>(size);
    let p = floor(centre + r * vec2<f32>(cos(a), sin(a)));
    // Off the screen: no depth to read, taken as visible.
    if p.x < 0.0 || p.y < 0.0 || p.x >= f32(size.x) || p.y >= f32(size.y) {
        return 1.0;
    }
    // Reverse Z: larger is nearer. Visible when the scene there is no
    // nearer than the light's limit.
    let d = textureLoad(depth, vec2<i32>(p), 0);
    return select(0.0, 1.0, d <= probe.depth_limit);
}

@compute @workgroup_size(64)
fn occlusion(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) t: u32) {
    let light = group.x;
    let probe = lights[light];
    let size = textureDimensions(depth);
    var sum = 0.0;
    for (var s = 0u; s < PER_THREAD; s += 1u) {
        sum += sample_visible(probe, t * PER_THREAD + s, size);
    }
    partial[t] = sum;
    workgroupBarrier();
    for (var stride = 32u; stride > 0u; stride /= 2u) {
        if t < stride {
            partial[t] += partial[t + stride];
        }
        workgroupBarrier();
    }
    if t == 0u {
        var v = partial[0] / f32(SAMPLES);
        if probe.read_depth == 0u {
            v = 1.0;
        }
        let cycle = params.jitter_cycle;
        if cycle > 0u {
            let ring = params.lights + light * cycle;
            if params.reset_history != 0u {
                for (var k = 0u; k < cycle; k += 1u) {
                    visibility[ring + k] = v;
                }
            }
            visibility[ring + params.jitter_slot % cycle] = v;
            var mean = 0.0;
            for (var k = 0u; k < cycle; k += 1u) {
                mean += visibility[ring + k];
            }
            v = mean / f32(cycle);
        }
        if params.reset_history == 0u {
            v = mix(v, visibility[light], params.occlusion_history);
        }
        visibility[light] = v;
    }
}
