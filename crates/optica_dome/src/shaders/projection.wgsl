// The dome camera's fisheye projection for vertex shaders: the WGSL twin
// of `optica_optics::dome::DomeProjection::project`, in clip space.
//
// A dome camera hands its parameters to the shaders through its
// `clip_from_view` (see the crate's `projection.rs`, `DomeClip`):
//   M = S · R, R the rotation from view space to the dome frame (rows:
//   image right = view +X, image up, −axis), S an infinite reverse-Z
//   perspective of focals (sx, sy) and near plane n, with
//   S[2][2] = e = THETA_SCALE·θ_max, the clip-x offset LENS_MARK·(1 + lens)
//   and a polynomial's shape (k₂, k₃, k₄)/k₁ in the clip-y offset and in
//   S[1][0], S[2][0].
// Row 3 of M is the dome axis (w = distance along it); e is read back from
// columns 1 and 2, where (M[c][2], M[c][3]) = (e·R[2][c], −R[2][c]); since
// R's first row is +X, M[0][1] = S[1][0], M[0][2] = S[2][0], M[0][0] = sx.
#define_import_path optica_dome::projection

// projection.rs THETA_SCALE.
const THETA_SCALE: f32 = 1.0e-4;
// projection.rs LENS_MARK.
const LENS_MARK: f32 = 1.0e-3;
// projection.rs INTERPOLATED.
const INTERPOLATED: i32 = 8;

const PI: f32 = 3.14159265358979;

// The lenses (settings.rs `DomeLens`, projection.rs `DomeClip::lens_code`).
const EQUIDISTANT: i32 = 0;
const EQUISOLID: i32 = 1;
const STEREOGRAPHIC: i32 = 2;
const ORTHOGRAPHIC: i32 = 3;
const POLYNOMIAL: i32 = 4;
const EQUIRECTANGULAR: i32 = 5;

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

// The number marked in `m` (1 + lens, plus INTERPOLATED where attributes
// stay interpolated), or 0.
fn mark_of(m: mat4x4<f32>) -> i32 {
    let k = m[3][0] / LENS_MARK;
    let n = round(k);
    if abs(k - n) > 1.0e-3 || n < 1.0 || n > 14.0 || (n > 6.0 && n < 9.0) {
        return 0;
    }
    return i32(n);
}

// The lens number marked in `m`, or −1.
fn lens_of(m: mat4x4<f32>) -> i32 {
    return (mark_of(m) - 1) % INTERPOLATED;
}

// Whether the dome view whose clip_from_view is `m` gives fragments their
// own ray's attributes (`DomeCamera::exact_attributes`).
fn exact_attributes(m: mat4x4<f32>) -> bool {
    let n = mark_of(m);
    return n >= 1 && n <= 6;
}

// Whether `m` is a dome camera's clip_from_view (a projection the mesh
// pipeline calls non-standard, with a lens mark, w = forward distance and
// an encoded θ_max in (0, π)).
fn is_dome(m: mat4x4<f32>) -> bool {
    let theta_max = theta_max_of(m);
    return lens_of(m) >= 0 && m[3][3] == 0.0 && theta_max > 0.0 && theta_max < 3.1416;
}

// A radial lens: which, its polynomial's shape and its field of view.
struct Lens {
    kind: i32,
    // (k₂, k₃, k₄)/k₁ for the polynomial.
    shape: vec3<f32>,
    theta_max: f32,
}

fn lens_from(m: mat4x4<f32>) -> Lens {
    return Lens(lens_of(m), vec3<f32>(m[3][1], m[0][1], m[0][2]), theta_max_of(m));
}

// g(θ) of the lens, without the continuation past the rim
// (`FisheyeLens::g` on the CPU; the polynomial divided by k₁).
fn lens_g(lens: Lens, t: f32) -> f32 {
    switch lens.kind {
        case 1: { return 2.0 * sin(0.5 * t); }
        case 2: { return 2.0 * tan(0.5 * t); }
        case 3: { return sin(t); }
        case 4: {
            let t2 = t * t;
            let c = lens.shape;
            return t * (1.0 + t2 * (c.x + t2 * (c.y + t2 * c.z)));
        }
        default: { return t; }
    }
}

// g'(θ).
fn lens_dg(lens: Lens, t: f32) -> f32 {
    switch lens.kind {
        case 1: { return cos(0.5 * t); }
        case 2: { let c = cos(0.5 * t); return 1.0 / (c * c); }
        case 3: { return cos(t); }
        case 4: {
            let t2 = t * t;
            let c = lens.shape;
            return 1.0 + t2 * (3.0 * c.x + t2 * (5.0 * c.y + t2 * 7.0 * c.z));
        }
        default: { return 1.0; }
    }
}

// Image radius of polar angle θ, as a fraction of the image circle's:
// g(θ)/g(θ_max), continued past the rim by a rising parabola for the
// orthographic and polynomial lenses (`RadialMap::radius` on the CPU).
fn lens_radius(lens: Lens, t: f32) -> f32 {
    let g_max = lens_g(lens, lens.theta_max);
    let continued = lens.kind == ORTHOGRAPHIC || lens.kind == POLYNOMIAL;
    if continued && t > lens.theta_max {
        let d = t - lens.theta_max;
        let slope = max(lens_dg(lens, lens.theta_max), 0.0);
        let bend = g_max / (lens.theta_max * lens.theta_max);
        return 1.0 + d * (slope + 0.5 * bend * d) / g_max;
    }
    return lens_g(lens, t) / g_max;
}

// Polar angle seen at a fraction `u` ∈ [0, 1] of the image circle's radius
// (`RadialMap::theta_of_radius` on the CPU).
fn lens_theta(lens: Lens, u: f32) -> f32 {
    let g = clamp(u, 0.0, 1.0) * lens_g(lens, lens.theta_max);
    switch lens.kind {
        case 1: { return 2.0 * asin(min(0.5 * g, 1.0)); }
        case 2: { return 2.0 * atan(0.5 * g); }
        case 3: { return asin(min(g, 1.0)); }
        case 4: {
            // Newton's method, kept in its bracket by bisection (g rises).
            var lo = 0.0;
            var hi = lens.theta_max;
            var t = clamp(u, 0.0, 1.0) * lens.theta_max;
            for (var i = 0; i < 24; i++) {
                let e = lens_g(lens, t) - g;
                if e > 0.0 { hi = t; } else { lo = t; }
                let newton = t - e / lens_dg(lens, t);
                t = select(0.5 * (lo + hi), newton, newton > lo && newton < hi);
            }
            return t;
        }
        default: { return g; }
    }
}

// Polar angle past which vertices are dropped: 7/8 of the way from the rim
// to the antipode (the CPU twin's `DomeProjection::theta_draw_limit`).
fn theta_draw_limit(theta_max: f32) -> f32 {
    return theta_max + 0.875 * (PI - theta_max);
}

// Clip position of dome coordinates `q` (right, up, along the axis): NDC
// radius g(θ)/g(θ_max) along the point's azimuth, scaled by `scale` (the
// image circle fits the target's shorter side; D1–D3, D9 of the CPU twin),
// radial reverse-Z depth n/|q|, and w = |q| so that attributes interpolate
// by radial distance.
//
// A vertex past the draw limit gets depth −1 (z = −w), outside the clip
// volume: a triangle with all its vertices there (around the antipode,
// where its image would wrap across the disk) is dropped whole, one
// straddling the limit is cut short far outside the image circle. Refined
// twins never reach the limit (they are clipped or culled nearer the rim);
// it guards geometry drawn without clipping (pre-subdivided meshes).
fn dome_clip(q: vec3<f32>, near: f32, lens: Lens, scale: vec2<f32>) -> vec4<f32> {
    let rho = length(q.xy);
    let theta = atan2(rho, q.z);
    var dir = vec2<f32>(0.0);
    if rho > 0.0 {
        dir = q.xy / rho;
    }
    let w = max(length(q), 1.0e-30);
    let ndc = dir * lens_radius(lens, theta) * scale;
    let z = select(near, -w, theta > theta_draw_limit(lens.theta_max));
    return vec4<f32>(ndc * w, z, w);
}

// Clip position of frame coordinates `q` (right, up, the image centre's
// direction) in the equirectangular panorama (E1 of the CPU twin,
// `optica_optics::dome::EquirectProjection`): NDC x = λ/π, y = φ/(π/2),
// filling the target; depth and w as `dome_clip`. The refinement has moved
// vertices on the seam and the poles off them (to their side), so atan2
// lands each where its triangle needs it.
fn equirect_clip(q: vec3<f32>, near: f32) -> vec4<f32> {
    let lon = atan2(q.x, q.z);
    let lat = atan2(q.y, length(q.xz));
    let w = max(length(q), 1.0e-30);
    let ndc = vec2<f32>(lon / PI, lat / (0.5 * PI));
    return vec4<f32>(ndc * w, near, w);
}

// Clip position of the view-space point `p` under the dome camera whose
// clip_from_view is `m` (check `is_dome(m)` first).
fn clip_of_view(p: vec3<f32>, m: mat4x4<f32>) -> vec4<f32> {
    // Image right is view +X; the axis is row 3; up = right × axis.
    let axis = vec3<f32>(m[0][3], m[1][3], m[2][3]);
    let up = cross(vec3<f32>(1.0, 0.0, 0.0), axis);
    let q = vec3<f32>(p.x, dot(up, p), dot(axis, p));
    let lens = lens_from(m);
    if lens.kind == EQUIRECTANGULAR {
        return equirect_clip(q, m[3][2]);
    }
    let scale = vec2<f32>(m[0][0], length(vec2<f32>(m[1][1], m[2][1])));
    return dome_clip(q, m[3][2], lens, scale);
}

// The unit view-space direction seen at the framebuffer position `frag`
// (a pixel centre) of the dome view whose clip_from_view is `m` (check
// `is_dome(m)` first) and whose viewport is `viewport` (x, y, width,
// height): the inverse of `clip_of_view` (`DomeProjection::unproject`,
// `EquirectProjection::unproject` on the CPU). w is 0 beyond the image
// circle, where no direction is seen.
fn view_ray(frag: vec2<f32>, viewport: vec4<f32>, m: mat4x4<f32>) -> vec4<f32> {
    let ndc = vec2<f32>(
        2.0 * (frag.x - viewport.x) / viewport.z - 1.0,
        1.0 - 2.0 * (frag.y - viewport.y) / viewport.w,
    );
    let lens = lens_from(m);
    var q: vec3<f32>;
    if lens.kind == EQUIRECTANGULAR {
        let lon = ndc.x * PI;
        let lat = ndc.y * 0.5 * PI;
        q = vec3<f32>(cos(lat) * sin(lon), sin(lat), cos(lat) * cos(lon));
    } else {
        let scale = vec2<f32>(m[0][0], length(vec2<f32>(m[1][1], m[2][1])));
        let v = ndc / scale;
        let u = length(v);
        let theta = lens_theta(lens, u);
        q = vec3<f32>(select(0.0, sin(theta) / u, u > 0.0) * v, cos(theta));
        if u > 1.0 {
            return vec4<f32>(0.0);
        }
    }
    // Dome coordinates (right, up, axis) back to view space.
    let axis = vec3<f32>(m[0][3], m[1][3], m[2][3]);
    let up = cross(vec3<f32>(1.0, 0.0, 0.0), axis);
    return vec4<f32>(vec3<f32>(q.x, 0.0, 0.0) + q.y * up + q.z * axis, 1.0);
}

// optica_optics::dome::fragment MAX_STEP_PX.
const MAX_STEP_PX: f32 = 64.0;
// optica_optics::dome::fragment GRAZING_SIN.
const GRAZING_SIN: f32 = 1.0e-4;

// The step (a, b) that moves a fragment's interpolated position `p` along
// its screen differences `dp_dx`, `dp_dy` to where the ray from `origin`
// along `ray` meets their plane: `p + a·dp_dx + b·dp_dy` lies on the ray,
// and every attribute interpolated with `p` moves by the same step along
// its own differences (D11, `optica_optics::dome::plane_step` on the
// CPU). Zero — keep the interpolated attributes — where the CPU twin
// gives none: differences (nearly) parallel, a grazing ray, a plane behind
// the origin, a step past MAX_STEP_PX or input that is not finite.
fn plane_step(origin: vec3<f32>, ray: vec3<f32>, p: vec3<f32>, dp_dx: vec3<f32>, dp_dy: vec3<f32>) -> vec2<f32> {
    // Every fragment runs this: no branch and no square root, one test of
    // all the conditions at the end.
    let n = cross(dp_dx, dp_dy);
    let nn = dot(n, n);
    let xx = dot(dp_dx, dp_dx);
    let xy = dot(dp_dx, dp_dy);
    let yy = dot(dp_dy, dp_dy);
    let across = dot(ray, n);
    let to_p = p - origin;
    let t = dot(to_p, n) / across;
    let delta = t * ray - to_p;
    let rx = dot(delta, dp_dx);
    let ry = dot(delta, dp_dy);
    // The Gram determinant xx·yy − xy² is |n|² (Lagrange's identity).
    let step = vec2<f32>(yy * rx - xy * ry, xx * ry - xy * rx) * (1.0 / nn);
    let eps2 = GRAZING_SIN * GRAZING_SIN;
    // NaN and infinity fail the comparisons.
    let ok = nn > eps2 * xx * yy && across * across > eps2 * nn * dot(ray, ray) && t > 0.0
        && abs(step.x) <= MAX_STEP_PX && abs(step.y) <= MAX_STEP_PX;
    return select(vec2<f32>(0.0), step, ok);
}
