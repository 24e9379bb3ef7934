// The equidistant (f-θ) dome projection for vertex shaders: the WGSL twin
// of `optica_optics::dome::DomeProjection::project`, in clip space.
//
// A dome camera hands its parameters to the shaders through its
// `clip_from_view` (see the crate's `projection.rs`, `DomeClip`):
//   M = S · R, R the rotation from view space to the dome frame (rows:
//   image right, image up, −axis), S Bevy's infinite reverse-Z perspective
//   of focal FOCAL and near plane n, with S[2][2] = e = THETA_SCALE·θ_max.
// So clip = M·p gives the dome coordinates q = (clip.x/FOCAL, clip.y/FOCAL,
// clip.w) with q.z along the dome axis, and e is read back from columns 1
// and 2, where (M[c][2], M[c][3]) = (e·R[2][c], −R[2][c]).
#define_import_path optica_dome::equidistant

// projection.rs FOCAL.
const FOCAL: f32 = 1.0;
// projection.rs THETA_SCALE.
const THETA_SCALE: f32 = 1.0e-4;

// θ_max (half the field of view, radians) encoded in `m`; 0 when `m` does
// not carry one.
fn theta_max_of(m: mat4x4<f32>) -> f32 {
    let num = m[1][2] * m[1][3] + m[2][2] * m[2][3];
    let den = m[1][3] * m[1][3] + m[2][3] * m[2][3];
    if !(den > 0.0) {
        return 0.0;
    }
    return -num / den / THETA_SCALE;
}

// Whether `m` is a dome camera's clip_from_view (a projection the mesh
// pipeline calls non-standard, with focal FOCAL, w = forward distance and an
// encoded θ_max in (0, π)).
fn is_dome(m: mat4x4<f32>) -> bool {
    let theta_max = theta_max_of(m);
    return m[0][0] == FOCAL && m[3][3] == 0.0 && theta_max > 0.0 && theta_max < 3.1416;
}

const PI: f32 = 3.14159265358979;

// Polar angle past which vertices are dropped: 7/8 of the way from the rim
// to the antipode (the CPU twin's `DomeProjection::theta_draw_limit`).
fn theta_draw_limit(theta_max: f32) -> f32 {
    return theta_max + 0.875 * (PI - theta_max);
}

// Clip position of dome coordinates `q` (right, up, along the axis): NDC
// radius θ/θ_max along the point's azimuth (D1–D3 of the CPU twin, with the
// image circle at NDC radius 1), radial reverse-Z depth n/|q|, and w = |q|
// so that attributes interpolate by radial distance.
//
// A vertex past the draw limit gets depth −1 (z = −w), outside the clip
// volume: a triangle with all its vertices there (around the antipode,
// where its image would wrap across the disk) is dropped whole, one
// straddling the limit is cut short far outside the image circle. Refined
// twins never reach the limit (they are clipped or culled nearer the rim);
// it guards geometry drawn without clipping (pre-subdivided meshes).
fn dome_clip(q: vec3<f32>, near: f32, theta_max: f32) -> vec4<f32> {
    let rho = length(q.xy);
    let theta = atan2(rho, q.z);
    var dir = vec2<f32>(0.0);
    if rho > 0.0 {
        dir = q.xy / rho;
    }
    let w = max(length(q), 1.0e-30);
    let ndc = dir * (theta / theta_max);
    let z = select(near, -w, theta > theta_draw_limit(theta_max));
    return vec4<f32>(ndc * w, z, w);
}

// Clip position of the view-space point `p` under the dome camera whose
// clip_from_view is `m` (check `is_dome(m)` first).
fn clip_of_view(p: vec3<f32>, m: mat4x4<f32>) -> vec4<f32> {
    let c = m * vec4<f32>(p, 1.0);
    let q = vec3<f32>(c.x / FOCAL, c.y / FOCAL, c.w);
    return dome_clip(q, m[3][2], theta_max_of(m));
}
