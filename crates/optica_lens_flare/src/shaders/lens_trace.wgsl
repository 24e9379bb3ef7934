#define_import_path optica_lens_flare::lens_trace

// Real-ray tracing of one ray through a sequential lens along a ghost path
// (two reflections) or the primary path: the WGSL twin of
// `optica_optics::lens::PreparedLens::trace_to`, in f32.
//
// The lens reaches it through two virtual functions, which the including
// shader overrides (an `override fn` of each), so that the
// plugin's compute pass (storage buffers) and the readback test (a flat
// input array, with the library pasted in and these two defined instead)
// share it.
//
// Conventions as in `optica_optics::lens`: mm, +z from object to sensor, the
// first vertex at z = 0, curvature c = 1/R (flat is exactly 0), indices
// evaluated at the trace's wavelength.

struct LensSurface {
    // Vertex z, mm.
    z: f32,
    // Curvature 1/R, 1/mm.
    c: f32,
    // Clear semi-aperture, mm.
    semi: f32,
    // Index in front of the surface and behind it.
    n_before: f32,
    n_after: f32,
    // 1 for the aperture stop (an opening: no refraction, no Fresnel).
    is_stop: f32,
    // Single-layer coating: index (0 = bare) and physical thickness, nm.
    coat_n: f32,
    coat_d_nm: f32,
}

virtual fn surface_count() -> u32 {
    // How many surfaces the lens has: overridden by the including shader.
    // (No comment may stand right above a `virtual fn`: naga_oil's rewrite
    // of the keyword joins the line to the one before it.)
    return 0u;
}

virtual fn surface_at(k: u32) -> LensSurface {
    // Surface `k`, the first at z = 0: overridden by the including shader.
    return LensSurface(0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0);
}

struct SurfaceHit {
    ok: bool,
    p: vec3<f32>,
    n: vec3<f32>,
}

// What a ray brings to the sensor (the twin of `TraceResult`).
struct TraceOut {
    alive: bool,
    sensor: vec2<f32>,
    r_rel: f32,
    // Every crossing of the stop plane; unused entries repeat the first.
    stop_first: vec2<f32>,
    stop_second: vec2<f32>,
    stop_third: vec2<f32>,
    throughput: f32,
}

// Hits closer than this (relative to the ray's unit length) are the
// surface the ray starts on. f32 positions of ~100 mm carry ~1e-5 mm of
// round-off (the CPU twin's 1e-9 is for f64).
const T_EPS: f32 = 1.0e-5;
// How far behind a ray's origin a touching surface (zero thickness) may be
// met, mm (the twin's 1e-7 scaled to f32 round-off).
const COINCIDENT_MM: f32 = 1.0e-4;
// Smallest exit d_z that reaches the sensor (the twin's MIN_EXIT_DIR_Z).
const MIN_EXIT_DIR_Z: f32 = 1.0e-7;
// Largest evanescent exponent kept in the coating (the twin's 40).
const MAX_EVANESCENT: f32 = 40.0;
const PI_F: f32 = 3.14159265358979;

fn miss() -> SurfaceHit {
    return SurfaceHit(false, vec3<f32>(0.0), vec3<f32>(0.0, 0.0, -1.0));
}

// The hit of the ray (o, unit d) on the cap through the vertex of the
// sphere z = vz, curvature c: the cancellation-free form of
// `SphericalSurface::intersect`.
fn intersect_cap(vz: f32, c: f32, o: vec3<f32>, d: vec3<f32>) -> SurfaceHit {
    let q = o - vec3<f32>(0.0, 0.0, vz);
    let qd = dot(q, d);
    let b = c * qd - d.z;
    let k = c * dot(q, q) - 2.0 * q.z;
    let q_perp = q - qd * d;
    let z_perp = vec3<f32>(0.0, 0.0, 1.0) - d.z * d;
    let e = c * q_perp - z_perp;
    let disc = 1.0 - dot(e, e);
    if !(disc >= 0.0) {
        return miss();
    }
    let sq = sqrt(disc);
    let sigma = select(1.0, -1.0, d.z < 0.0);
    var t: f32;
    if b * sigma > 0.0 {
        t = (-b - sigma * sq) / c;
    } else {
        let den = -b + sigma * sq;
        if den == 0.0 {
            return miss();
        }
        t = k / den;
    }
    if !(t > T_EPS && t < 1.0e30) {
        return miss();
    }
    let p = o + d * t;
    if c * (p.z - vz) > 1.0 {
        return miss();
    }
    let qh = p - vec3<f32>(0.0, 0.0, vz);
    var n = c * qh - vec3<f32>(0.0, 0.0, 1.0);
    let len = length(n);
    if len > 0.0 {
        n = n / len;
    } else {
        n = vec3<f32>(0.0, 0.0, -1.0);
    }
    return SurfaceHit(true, p, n);
}

// `intersect_cap`, allowing a touching surface just behind the origin (the
// twin's `PreparedLens::hit`).
fn hit_surface(vz: f32, c: f32, o: vec3<f32>, d: vec3<f32>) -> SurfaceHit {
    let h = intersect_cap(vz, c, o, d);
    if h.ok {
        return h;
    }
    let back = intersect_cap(vz, c, o - d * COINCIDENT_MM, d);
    if back.ok && dot(back.p - (o - d * COINCIDENT_MM), d) <= 2.0 * COINCIDENT_MM + T_EPS {
        return back;
    }
    return miss();
}

// cos² of the refracted angle, in the form that does not cancel at grazing
// incidence (`fresnel::cos_sq_refracted`).
fn cos_sq_refracted(cos_i: f32, n1: f32, n2: f32) -> f32 {
    return ((n2 - n1) * (n2 + n1) + n1 * n1 * cos_i * cos_i) / (n2 * n2);
}

// Unpolarised Fresnel reflectance of a bare interface; 1 on total internal
// reflection or grazing incidence (`fresnel::fresnel_unpolarized`).
fn fresnel_bare(cos_i: f32, n1: f32, n2: f32) -> f32 {
    if n1 == n2 {
        return 0.0;
    }
    let ct2 = cos_sq_refracted(cos_i, n1, n2);
    if ct2 < 0.0 || cos_i == 0.0 {
        return 1.0;
    }
    let ct = sqrt(ct2);
    let rs = (n1 * cos_i - n2 * ct) / (n1 * cos_i + n2 * ct);
    let rp = (n2 * cos_i - n1 * ct) / (n2 * cos_i + n1 * ct);
    return 0.5 * (rs * rs + rp * rp);
}

// One polarisation of a single layer (`fresnel::film_reflectance`).
fn film_reflectance(eta0: f32, eta1_sq: f32, eta2: f32, cos_d: f32, s: f32) -> f32 {
    let a = (eta0 - eta2) * cos_d;
    let b = s * (eta0 * eta2 - eta1_sq);
    let c = (eta0 + eta2) * cos_d;
    let d = s * (eta0 * eta2 + eta1_sq);
    let den = c * c + d * d;
    if den > 0.0 {
        return clamp((a * a + b * b) / den, 0.0, 1.0);
    }
    return 1.0;
}

// Exact unpolarised reflectance of a single layer (index nc, thickness
// d_nm) between n1 and n2 (`fresnel::try_single_layer_reflectance`).
fn coated_reflectance(cos_i: f32, n1: f32, nc: f32, d_nm: f32, n2: f32, wl_nm: f32) -> f32 {
    let ct2 = cos_sq_refracted(cos_i, n1, n2);
    if ct2 < 0.0 {
        return 1.0;
    }
    if cos_i == 0.0 {
        return select(1.0, 0.0, n1 == n2 && nc == n1);
    }
    let cos2 = sqrt(ct2);
    let cosc_sq = cos_sq_refracted(cos_i, n1, nc);
    let k = 2.0 * PI_F * d_nm / wl_nm;
    let phase_sq = k * k * nc * nc * cosc_sq;
    var cos_d: f32;
    var sinc: f32;
    if phase_sq >= 0.0 {
        let x = sqrt(phase_sq);
        cos_d = cos(x);
        sinc = select(sin(x) / x, 1.0 - x * x / 6.0, x < 1.0e-2);
    } else {
        let y = min(sqrt(-phase_sq), MAX_EVANESCENT);
        cos_d = cosh(y);
        sinc = select(sinh(y) / y, 1.0 + y * y / 6.0, y < 1.0e-2);
    }
    let rs = film_reflectance(n1 * cos_i, nc * nc * cosc_sq, n2 * cos2, cos_d, k * sinc);
    let rp = film_reflectance(cos_i / n1, cosc_sq / (nc * nc), cos2 / n2, cos_d, k * nc * nc * sinc);
    return 0.5 * (rs + rp);
}

// The state of a ray along its path.
struct RayState {
    alive: bool,
    o: vec3<f32>,
    d: vec3<f32>,
    r_rel: f32,
    throughput: f32,
    // The first three crossings of the stop plane (fields, not an array:
    // a dynamically indexed local array costs every invocation).
    stop_first: vec2<f32>,
    stop_second: vec2<f32>,
    stop_third: vec2<f32>,
    crossings: u32,
}

// Meets surface k travelling forward (+z) or backward, then refracts
// (`reflect` false) or reflects (`PreparedLens::interact`).
fn interact(st: ptr<function, RayState>, k: u32, forward: bool, reflect_here: bool, wl_nm: f32) {
    if !(*st).alive {
        return;
    }
    let s = surface_at(k);
    let h = hit_surface(s.z, s.c, (*st).o, (*st).d);
    if !h.ok {
        (*st).alive = false;
        return;
    }
    let r = length(h.p.xy);
    (*st).r_rel = max((*st).r_rel, r / s.semi);
    if s.is_stop > 0.5 {
        switch (*st).crossings {
            case 0u: {
                (*st).stop_first = h.p.xy;
            }
            case 1u: {
                (*st).stop_second = h.p.xy;
            }
            case 2u: {
                (*st).stop_third = h.p.xy;
            }
            default: {}
        }
        (*st).crossings += 1u;
        (*st).o = h.p;
        return;
    }
    var n1 = s.n_before;
    var n2 = s.n_after;
    if !forward {
        n1 = s.n_after;
        n2 = s.n_before;
    }
    let d = (*st).d;
    let cos_i = min(abs(dot(d, h.n)), 1.0);
    var refl: f32;
    if s.coat_n > 0.0 {
        refl = coated_reflectance(cos_i, n1, s.coat_n, s.coat_d_nm, n2, wl_nm);
    } else {
        refl = fresnel_bare(cos_i, n1, n2);
    }
    var nd: vec3<f32>;
    if reflect_here {
        (*st).throughput *= refl;
        nd = d - 2.0 * dot(d, h.n) * h.n;
    } else {
        // Snell (`surface::refract`): the normal turned against d.
        var n = h.n;
        var ci = -dot(n, d);
        if ci < 0.0 {
            n = -n;
            ci = -ci;
        }
        ci = min(ci, 1.0);
        let ct2 = cos_sq_refracted(ci, n1, n2);
        if ct2 < 0.0 {
            (*st).alive = false;
            return;
        }
        let eta = n1 / n2;
        nd = normalize(eta * d + (eta * ci - sqrt(ct2)) * n);
        (*st).throughput *= 1.0 - refl;
    }
    (*st).o = h.p;
    (*st).d = nd;
}

// Traces the ray (o, unit d) to the plane z = sensor_z along the ghost
// path (first, second) — reflect at `first`, then at `second < first` — or,
// with first == second, the primary path.
fn trace_ray(o: vec3<f32>, d: vec3<f32>, first: u32, second: u32, sensor_z: f32, wl_nm: f32) -> TraceOut {
    var st = RayState(true, o, d, 0.0, 1.0, vec2<f32>(0.0), vec2<f32>(0.0), vec2<f32>(0.0), 0u);
    let last = surface_count() - 1u;
    // One loop over the path's steps (one call of `interact`, inlined
    // once, instead of one per leg): forward to `first`, reflect, back to
    // `second`, reflect, forward to the last surface.
    let ghost = first != second;
    let back_end = 2u * first - second;
    let steps = select(last + 1u, back_end + 1u + last - second, ghost);
    for (var step = 0u; step < steps && st.alive; step++) {
        var k = step;
        var forward = true;
        if ghost && step > first {
            if step < back_end {
                k = 2u * first - step;
                forward = false;
            } else if step == back_end {
                k = second;
                forward = false;
            } else {
                k = step + 2u * second - 2u * first;
            }
        }
        let reflect_here = ghost && (step == first || step == back_end);
        interact(&st, k, forward, reflect_here, wl_nm);
    }
    var out = TraceOut(false, vec2<f32>(0.0), 0.0, vec2<f32>(0.0), vec2<f32>(0.0), vec2<f32>(0.0), 0.0);
    if !st.alive || !(st.d.z >= MIN_EXIT_DIR_Z) {
        return out;
    }
    let t = (sensor_z - st.o.z) / st.d.z;
    let p = st.o + st.d * t;
    if !(abs(p.x) < 1.0e30 && abs(p.y) < 1.0e30 && st.r_rel < 1.0e30 && st.throughput >= 0.0) {
        return out;
    }
    out.alive = true;
    out.sensor = p.xy;
    out.r_rel = st.r_rel;
    out.stop_first = st.stop_first;
    out.stop_second = select(st.stop_first, st.stop_second, st.crossings > 1u);
    out.stop_third = select(st.stop_first, st.stop_third, st.crossings > 2u);
    out.throughput = st.throughput;
    return out;
}
