// The compound-eye optics in WGSL: the twin of `optica_optics::compound_eye`
// (shading_path.rs, lattice.rs, lattice_kind.rs, ball_lens.rs, pigment.rs),
// step for step, in f32. Equation numbers are Sagawa's thesis (2014), ch. 6.
// Positions are relative to the fragment (the fragment is the origin), which
// keeps f32 round-off at the scale of a facet.

#define_import_path optica::compound_eye

// lattice_kind.rs: √3/2, the row spacing of the hexagonal lattice (facets).
const ROW: f32 = 0.8660254;
// lattice.rs MIN_COS, the f32 equivalent: rays closer to parallel with the
// polygon than this do not go deeper.
const MIN_COS: f32 = 1e-6;
// lattice.rs LENGTH_REL_EPS in f32: f32 sphere intersections are good to
// ~1e-6 relative, so a point within 1e-4 r of a surface is on it.
const LENGTH_REL_EPS: f32 = 1e-4;
// shading_path.rs MAX_SLICES and MAX_LENSES: the loop bounds.
const MAX_SLICES: u32 = 64u;
const MAX_LENSES: u32 = 4u;
// exact_tracer.rs MAX_WALK_CELLS and MAX_EXACT_LENSES: the exact path's
// loop bounds.
const MAX_WALK_CELLS: u32 = 64u;
const MAX_EXACT_LENSES: u32 = 16u;
// shading_path.rs NEIGHBOUR_SPAN_CELLS.
const NEIGHBOUR_SPAN_CELLS: f32 = 4.0;
// pigment.rs PREFILTER_START / PREFILTER_FULL.
const PREFILTER_START: f32 = 0.25;
const PREFILTER_FULL: f32 = 1.0;

const KIND_SQUARE: u32 = 0u;
const KIND_HEXAGONAL: u32 = 1u;

// What a traced fragment reached (outcome.rs).
const OUTCOME_PIGMENT: u32 = 0u;
const OUTCOME_ESCAPED: u32 = 1u;
const OUTCOME_FALLBACK: u32 = 2u;

// One triangle's lattice (lattice.rs `Lattice` + texture_axes.rs `TextureAxes`).
struct Lattice {
    // P_c of eq. 6.3, relative to the fragment.
    origin: vec3<f32>,
    // U_p, V_p (eq. 6.8–6.9): world vectors of one facet along u and v.
    u: vec3<f32>,
    v: vec3<f32>,
    // Unit outward normal N of the polygon (lenses lie on the −N side).
    n: vec3<f32>,
    uu: f32,
    vv: f32,
    uv: f32,
    gram: f32,
    kind: u32,
    // Lens radius r, relative index n, pigment depth d (world units).
    r: f32,
    index: f32,
    depth: f32,
}

struct Cell {
    index: vec2<f32>,
    centre_uv: vec2<f32>,
}

struct Trace {
    outcome: u32,
    // Pigment-plane texture coordinate (facets), for OUTCOME_PIGMENT.
    uv: vec2<f32>,
    // Power the lens surfaces let through.
    transmittance: f32,
    // Lenses passed.
    lenses: u32,
    // Direction of an escaping ray, for OUTCOME_ESCAPED.
    dir: vec3<f32>,
}

// texture_axes.rs MIN_SHADING_COS: the shading normal is followed within
// 60° of the lattice's.
const MIN_SHADING_COS: f32 = 0.5;

// texture_axes.rs `TextureAxes::on_normal`: the axes `u`, `v` (normal `n`)
// projected into the plane perpendicular to the shading normal `s`, taken
// on n's side; returns (u, v, normal). Unchanged where `s` is zero or not
// finite, more than 60° off `n`, or the projected axes are (nearly)
// parallel (the shader's UV_DET_REL_EPS, 1e-4).
fn axes_on_normal(u: vec3<f32>, v: vec3<f32>, n: vec3<f32>, s: vec3<f32>) -> array<vec3<f32>, 3> {
    let kept = array<vec3<f32>, 3>(u, v, n);
    let len = length(s);
    if !(len > 0.0 && len < 3.0e38) {
        return kept;
    }
    var m = s / len;
    if dot(m, n) < 0.0 {
        m = -m;
    }
    if !(dot(m, n) > MIN_SHADING_COS) {
        return kept;
    }
    let pu = u - dot(u, m) * m;
    let pv = v - dot(v, m) * m;
    if !(length(cross(pu, pv)) > 1e-4 * length(pu) * length(pv)) {
        return kept;
    }
    return array<vec3<f32>, 3>(pu, pv, m);
}

// texture_axes.rs `TextureAxes::on_tangent`: the axes `u`, `v` (normal `n`)
// turned to follow the in-plane part of `tangent`, square and of the same
// cell area; returns (u, v). Unchanged where the tangent is zero, not
// finite or (within 1e-4 in sine) along the normal.
fn axes_on_tangent(u: vec3<f32>, v: vec3<f32>, n: vec3<f32>, tangent: vec3<f32>) -> array<vec3<f32>, 2> {
    let in_plane = tangent - dot(tangent, n) * n;
    if !(length(in_plane) > 1e-4 * length(tangent)) {
        return array<vec3<f32>, 2>(u, v);
    }
    let frame = unit_frame(u, v, n, in_plane);
    let side = sqrt(length(cross(u, v)));
    return array<vec3<f32>, 2>(side * frame[0], side * frame[1]);
}

// The unit frame (T, B) of a tangent's in-plane part `in_plane` (not
// zero): T along it on `u`'s side, B = n × T on `v`'s side.
fn unit_frame(u: vec3<f32>, v: vec3<f32>, n: vec3<f32>, in_plane: vec3<f32>) -> array<vec3<f32>, 2> {
    var t = normalize(in_plane);
    if dot(t, u) < 0.0 {
        t = -t;
    }
    var b = cross(n, t);
    if dot(b, v) < 0.0 {
        b = -b;
    }
    return array<vec3<f32>, 2>(t, b);
}

// texture_axes.rs `TextureAxes::on_field`: the axes `u`, `v` (normal `n`)
// laid along a smooth axis field, `u` along the in-plane part of `tangent`
// and `v = |u|·(shape.x·T + shape.y·B)`, of the same cell area; returns
// (u, v). The tangent frame's square axes where the shape is not finite
// or its aspect `shape.y` is not above 1e-4; unchanged where the tangent
// is zero, not finite or (within 1e-4 in sine) along the normal.
fn axes_on_field(u: vec3<f32>, v: vec3<f32>, n: vec3<f32>, tangent: vec3<f32>, shape: vec2<f32>) -> array<vec3<f32>, 2> {
    let in_plane = tangent - dot(tangent, n) * n;
    if !(length(in_plane) > 1e-4 * length(tangent)) {
        return array<vec3<f32>, 2>(u, v);
    }
    // NaN fails every comparison.
    if !(shape.y > 1e-4 && shape.y < 3.0e38 && abs(shape.x) < 3.0e38) {
        return axes_on_tangent(u, v, n, tangent);
    }
    let frame = unit_frame(u, v, n, in_plane);
    let side = sqrt(length(cross(u, v)) / shape.y);
    return array<vec3<f32>, 2>(side * frame[0], side * (shape.x * frame[0] + shape.y * frame[1]));
}

fn make_lattice(origin: vec3<f32>, u: vec3<f32>, v: vec3<f32>, n: vec3<f32>, kind: u32) -> Lattice {
    var l: Lattice;
    l.origin = origin;
    l.u = u;
    l.v = v;
    l.n = n;
    l.uu = dot(u, u);
    l.vv = dot(v, v);
    l.uv = dot(u, v);
    l.gram = l.uu * l.vv - l.uv * l.uv;
    l.kind = kind;
    return l;
}

// texture_axes.rs `uv_rate` (eq. 6.26–6.27 on a direction).
fn uv_rate(l: Lattice, d: vec3<f32>) -> vec2<f32> {
    let du = dot(d, l.u);
    let dv = dot(d, l.v);
    return vec2<f32>((l.vv * du - l.uv * dv) / l.gram, (l.uu * dv - l.uv * du) / l.gram);
}

// texture_axes.rs `uv_of` (eq. 6.25–6.27).
fn uv_of(l: Lattice, p: vec3<f32>) -> vec2<f32> {
    return uv_rate(l, p - l.origin);
}

// texture_axes.rs `point_of` (eq. 6.2).
fn point_of(l: Lattice, t: vec2<f32>) -> vec3<f32> {
    return l.origin + t.x * l.u + t.y * l.v;
}

// texture_axes.rs `depth`: depth below the polygon along −N.
fn depth_of(l: Lattice, p: vec3<f32>) -> f32 {
    return dot(l.origin - p, l.n);
}

// lattice_kind.rs: the square rule of eq. 6.17–6.20 for one coordinate.
fn square_centre_coord(x: f32) -> f32 {
    if x >= 0.0 {
        return floor(x) + 0.5;
    }
    return ceil(x) - 0.5;
}

// lattice_kind.rs `centre_of_index`.
fn centre_of_index(kind: u32, index: vec2<f32>) -> vec2<f32> {
    if kind == KIND_HEXAGONAL {
        return vec2<f32>(index.x + 0.5 * index.y, ROW * index.y);
    }
    return index + vec2<f32>(0.5);
}

// lattice_kind.rs `cell_of`.
fn cell_of(kind: u32, t: vec2<f32>) -> Cell {
    var c: Cell;
    if kind == KIND_HEXAGONAL {
        let j = t.y / ROW;
        let q = t.x - 0.5 * j;
        let r = j;
        let s = -q - r;
        var rq = round(q);
        var rr = round(r);
        let rs = round(s);
        let dq = abs(rq - q);
        let dr = abs(rr - r);
        let ds = abs(rs - s);
        if dq > dr && dq > ds {
            rq = -rr - rs;
        } else if dr > ds {
            rr = -rq - rs;
        }
        c.index = vec2<f32>(rq, rr);
        c.centre_uv = centre_of_index(kind, c.index);
    } else {
        c.centre_uv = vec2<f32>(square_centre_coord(t.x), square_centre_coord(t.y));
        c.index = round(c.centre_uv - vec2<f32>(0.5));
    }
    return c;
}

// lattice_kind.rs `cell_inradius`.
fn cell_inradius(kind: u32, u: vec3<f32>, v: vec3<f32>) -> f32 {
    let normal = cross(u, v);
    var best = 3.4e38;
    var count = 2u;
    if kind == KIND_HEXAGONAL {
        count = 3u;
    }
    for (var k = 0u; k < count; k++) {
        var nb = vec2<f32>(1.0, 0.0);
        if k == 1u {
            nb = select(vec2<f32>(0.0, 1.0), vec2<f32>(0.5, ROW), kind == KIND_HEXAGONAL);
        } else if k == 2u {
            nb = vec2<f32>(-0.5, ROW);
        }
        let edge = -nb.y * u + nb.x * v; // the bisector's direction, perp(n) in world
        let m = normalize(cross(normal, edge));
        best = min(best, abs(0.5 * dot(nb.x * u + nb.y * v, m)));
    }
    return best;
}

// lattice.rs `lens_centre` (eq. 6.21–6.22).
fn lens_centre(l: Lattice, centre_uv: vec2<f32>) -> vec3<f32> {
    return point_of(l, centre_uv) - l.r * l.n;
}

// lattice.rs `lens_entry` with surface.rs `intersect_sphere` (cancellation-free
// roots): the distance along the ray to where it enters the sphere, or −1.
fn lens_entry(l: Lattice, o: vec3<f32>, d: vec3<f32>, c: vec3<f32>) -> f32 {
    let eps = LENGTH_REL_EPS * l.r;
    let oc = o - c;
    let b = dot(oc, d);
    let cterm = dot(oc, oc) - l.r * l.r;
    let perp = oc - b * d;
    let disc = l.r * l.r - dot(perp, perp);
    if disc < 0.0 {
        return -1.0;
    }
    let s = sqrt(disc);
    let q = -(b + select(s, -s, b < 0.0));
    var t0 = 0.0;
    var t1 = 0.0;
    if q != 0.0 {
        t0 = cterm / q;
        t1 = q;
    }
    let t_near = min(t0, t1);
    let t_far = max(t0, t1);
    if t_far > eps && t_near > -eps {
        return max(t_near, 0.0);
    }
    return -1.0;
}

// fresnel.rs `cos_sq_refracted`.
fn cos_sq_refracted(cos_i: f32, n1: f32, n2: f32) -> f32 {
    return ((n2 - n1) * (n2 + n1) + n1 * n1 * cos_i * cos_i) / (n2 * n2);
}

// surface.rs `refract`: zero vector on total internal reflection.
fn refract_dir(d: vec3<f32>, normal: vec3<f32>, n1: f32, n2: f32) -> vec3<f32> {
    var n = normal;
    var cos_i = -dot(n, d);
    if cos_i < 0.0 {
        n = -n;
        cos_i = -cos_i;
    }
    cos_i = min(cos_i, 1.0);
    let eta = n1 / n2;
    let cos2_t = cos_sq_refracted(cos_i, n1, n2);
    // `!(≥ 0)` also turns a NaN (from an overflowing index) into "no ray".
    if !(cos2_t >= 0.0) {
        return vec3<f32>(0.0);
    }
    return normalize(eta * d + (eta * cos_i - sqrt(cos2_t)) * n);
}

// fresnel.rs `try_fresnel_sp` + `fresnel_unpolarized`.
fn fresnel_unpolarized(cos_in: f32, n1: f32, n2: f32) -> f32 {
    let cos_i = min(abs(cos_in), 1.0);
    if n1 == n2 {
        return 0.0;
    }
    let cos2_t = cos_sq_refracted(cos_i, n1, n2);
    if !(cos2_t >= 0.0) || cos_i == 0.0 {
        return 1.0;
    }
    let cos_t = sqrt(cos2_t);
    let rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    let rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
    return 0.5 * (rs * rs + rp * rp);
}

struct BallExit {
    ok: bool,
    exit: vec3<f32>,
    dir: vec3<f32>,
    transmittance: f32,
}

// ball_lens.rs `refract_through_ball` (eq. 6.28 at entry and exit).
fn refract_through_ball(entry_point: vec3<f32>, dir: vec3<f32>, centre: vec3<f32>, l: Lattice) -> BallExit {
    var out: BallExit;
    out.ok = false;
    let offset = entry_point - centre;
    var n_d = -dir;
    if dot(offset, offset) > 0.0 {
        n_d = normalize(offset);
    }
    let d = centre + l.r * n_d;
    let inside = refract_dir(dir, n_d, 1.0, l.index);
    if dot(inside, inside) == 0.0 {
        return out;
    }
    let chord = max(-2.0 * l.r * dot(n_d, inside), 0.0);
    let exit = d + chord * inside;
    var n_x = inside;
    if dot(exit - centre, exit - centre) > 0.0 {
        n_x = normalize(exit - centre);
    }
    let leaving = refract_dir(inside, n_x, l.index, 1.0);
    if dot(leaving, leaving) == 0.0 {
        return out;
    }
    let r_in = fresnel_unpolarized(dot(dir, n_d), 1.0, l.index);
    let r_out = fresnel_unpolarized(dot(inside, n_x), l.index, 1.0);
    out.ok = true;
    out.exit = exit;
    out.dir = leaving;
    out.transmittance = (1.0 - r_in) * (1.0 - r_out);
    return out;
}

// shading_path.rs `finish` (eq. 6.29): on to the pigment plane.
fn finish(l: Lattice, o: vec3<f32>, d: vec3<f32>, lenses: u32, transmittance: f32) -> Trace {
    var t: Trace;
    t.lenses = lenses;
    t.transmittance = transmittance;
    let down = -dot(d, l.n);
    if !(down > MIN_COS) {
        if lenses > 0u {
            t.outcome = OUTCOME_ESCAPED;
            t.dir = d;
        } else {
            t.outcome = OUTCOME_FALLBACK;
        }
        return t;
    }
    let s = (l.depth - depth_of(l, o)) / down;
    let p = o + max(s, 0.0) * d;
    t.outcome = OUTCOME_PIGMENT;
    t.uv = uv_of(l, p + l.depth * l.n); // (6.29): projected back onto the polygon
    return t;
}

struct NextLens {
    found: bool,
    cell: Cell,
    centre: vec3<f32>,
    t: f32,
}

// shading_path.rs `next_lens`: the neighbour the exit ray enters next.
fn next_lens(l: Lattice, o: vec3<f32>, d: vec3<f32>, current: vec2<f32>, samples: u32) -> NextLens {
    var found: NextLens;
    found.found = false;
    let h0 = depth_of(l, o);
    let down = -dot(d, l.n);
    let span = NEIGHBOUR_SPAN_CELLS * 2.0 * cell_inradius(l.kind, l.u, l.v);
    var t_layer = span;
    if down > MIN_COS {
        t_layer = (2.0 * l.r - h0) / down;
    } else if down < -MIN_COS {
        t_layer = h0 / -down;
    }
    let t_end = min(t_layer, span);
    if !(t_end > 0.0) {
        return found;
    }
    for (var s = 1u; s <= samples; s++) {
        let q = o + (t_end * f32(s) / f32(samples)) * d;
        let cell = cell_of(l.kind, uv_of(l, q + depth_of(l, q) * l.n));
        if all(cell.index == current) {
            continue;
        }
        let c = lens_centre(l, cell.centre_uv);
        let t_in = lens_entry(l, o, d, c);
        if t_in >= 0.0 {
            found.found = true;
            found.cell = cell;
            found.centre = c;
            found.t = t_in;
            return found;
        }
    }
    return found;
}

// shading_path.rs `shade_fragment_with`: the fragment ray starts at `p` on
// the polygon and runs along `d` (camera → fragment).
fn shade_fragment(l: Lattice, p: vec3<f32>, d: vec3<f32>, slices: u32, max_lenses_in: u32) -> Trace {
    var t: Trace;
    let cos = -dot(d, l.n);
    if !(cos > MIN_COS) {
        t.outcome = OUTCOME_FALLBACK;
        return t;
    }
    let k = min(slices, MAX_SLICES);
    // Step 2: slice-plane search (6.16–6.27).
    var found = false;
    var cell: Cell;
    var centre = vec3<f32>(0.0);
    var t_entry = 0.0;
    for (var s = 0u; s <= k; s++) {
        var h = 0.0;
        if k > 0u {
            h = l.r * f32(s) / f32(k);
        }
        let p_s = p + (h / cos) * d;
        let c = cell_of(l.kind, uv_of(l, p_s + h * l.n)); // (6.23)–(6.27), (6.17)–(6.20)
        let cc = lens_centre(l, c.centre_uv); // (6.21)–(6.22)
        let te = lens_entry(l, p, d, cc);
        if te >= 0.0 {
            found = true;
            cell = c;
            centre = cc;
            t_entry = te;
            break;
        }
    }
    if !found {
        return finish(l, p, d, 0u, 1.0);
    }
    // Step 3: refraction in and out (6.28), then into neighbours.
    let max_lenses = clamp(max_lenses_in, 1u, MAX_LENSES);
    var o = p;
    var dir = d;
    var transmittance = 1.0;
    var count = 0u;
    for (var guard = 0u; guard < MAX_LENSES; guard++) {
        let out = refract_through_ball(o + t_entry * dir, dir, centre, l);
        if !out.ok {
            t.outcome = OUTCOME_FALLBACK;
            return t;
        }
        o = out.exit;
        dir = out.dir;
        transmittance *= out.transmittance;
        count += 1u;
        if count >= max_lenses {
            break;
        }
        let next = next_lens(l, o, dir, cell.index, max(k, 1u));
        if !next.found {
            break;
        }
        cell = next.cell;
        centre = next.centre;
        t_entry = next.t;
    }
    return finish(l, o, dir, count, transmittance);
}

// lattice_kind.rs `lattice_rate`: a texture-coordinate step in lattice
// coordinates (the square cells, or the hexagonal lattice's axial ones).
fn lattice_rate(kind: u32, duv: vec2<f32>) -> vec2<f32> {
    if kind == KIND_HEXAGONAL {
        let dj = duv.y / ROW;
        return vec2<f32>(duv.x - 0.5 * dj, dj);
    }
    return duv;
}

// lattice_kind.rs `to_lattice`.
fn to_lattice(kind: u32, uv: vec2<f32>) -> vec2<f32> {
    if kind == KIND_HEXAGONAL {
        return lattice_rate(kind, uv);
    }
    return uv - vec2<f32>(0.5);
}

// What a walk across the lens layer found.
const WALK_NONE: u32 = 0u;
const WALK_FOUND: u32 = 1u;
const WALK_LIMIT: u32 = 2u;

struct Walk {
    status: u32,
    index: vec2<f32>,
    centre: vec3<f32>,
    t: f32,
}

// 1/|x|, or "never" for 0 (f32 division by zero is not defined in WGSL).
fn inv_abs(x: f32) -> f32 {
    return select(1.0 / abs(x), 3.0e38, x == 0.0);
}

// exact_tracer.rs `next` in `first_lens`: where the ray leaves cell `c`
// along one lattice coordinate.
fn next_boundary(c: f32, u: f32, d: f32, t_start: f32) -> f32 {
    if d > 0.0 {
        return t_start + (c + 1.0 - u) / d;
    } else if d < 0.0 {
        return t_start + (c - u) / d;
    }
    return 3.0e38;
}

// exact_tracer.rs `first_lens`: the nearest lens the ray (o, d) enters in
// the lens layer (depth 0 to 2r), not `exclude` when `has_exclude`, by a
// 2-D Amanatides–Woo walk over the lattice's unit cells, testing at each
// cell the lenses at its corners, the only ones whose columns reach it.
fn walk_first_lens(l: Lattice, o: vec3<f32>, d: vec3<f32>, exclude: vec2<f32>, has_exclude: bool) -> Walk {
    var w: Walk;
    w.status = WALK_NONE;
    let eps = LENGTH_REL_EPS * l.r;
    let h0 = depth_of(l, o);
    let down = -dot(d, l.n);
    let lo = -eps;
    let hi = 2.0 * l.r + eps;
    var t_start = 0.0;
    var t_end = 0.0;
    if down > 0.0 {
        t_start = max((lo - h0) / down, 0.0);
        t_end = (hi - h0) / down;
    } else if down < 0.0 {
        t_start = max((hi - h0) / down, 0.0);
        t_end = (lo - h0) / down;
    } else if h0 >= lo && h0 <= hi {
        t_end = 3.0e38;
    } else {
        return w;
    }
    if !(t_end >= t_start) {
        return w;
    }
    let uv0 = to_lattice(l.kind, uv_of(l, o + t_start * d));
    let duv = lattice_rate(l.kind, uv_rate(l, d));
    var cell = floor(uv0);
    let step = sign(duv);
    var t_max = vec2<f32>(next_boundary(cell.x, uv0.x, duv.x, t_start),
        next_boundary(cell.y, uv0.y, duv.y, t_start));
    let t_delta = vec2<f32>(inv_abs(duv.x), inv_abs(duv.y));
    // lattice_kind.rs `WALK_CORNERS`: the cell's four corners. A step to
    // the next cell brings two new ones; the two it shares with the
    // previous cell are not tested again.
    var prev = cell;
    for (var k = 0u; k < MAX_WALK_CELLS; k++) {
        for (var corner = 0u; corner < 4u; corner++) {
            let index = cell + vec2<f32>(f32(corner & 1u), f32(corner >> 1u));
            let rel = index - prev;
            let seen = k > 0u && all(rel >= vec2<f32>(0.0)) && all(rel <= vec2<f32>(1.0));
            if seen || (has_exclude && all(index == exclude)) {
                continue;
            }
            let c = lens_centre(l, centre_of_index(l.kind, index));
            let t = lens_entry(l, o, d, c);
            if t >= 0.0 && (w.status != WALK_FOUND || t < w.t) {
                w.status = WALK_FOUND;
                w.index = index;
                w.centre = c;
                w.t = t;
            }
        }
        let t_exit = min(t_max.x, t_max.y);
        // Every lens entered before t_exit has been tested (lenses stay in
        // their columns), so the nearest hit so far is final.
        if (w.status == WALK_FOUND && w.t <= t_exit) || t_exit >= t_end {
            return w;
        }
        prev = cell;
        if t_max.x < t_max.y {
            cell.x += step.x;
            t_max.x += t_delta.x;
        } else {
            cell.y += step.y;
            t_max.y += t_delta.y;
        }
    }
    w.status = WALK_LIMIT;
    return w;
}

// exact_tracer.rs `trace_exact_capped` from the fragment `p` on the polygon
// along `d`: the first lens the ray really meets, refracted in and out, then
// every lens the exit ray meets in turn, up to `max_lenses_in`, then the
// pigment plane.
fn shade_exact(l: Lattice, p: vec3<f32>, d: vec3<f32>, max_lenses_in: u32) -> Trace {
    var t: Trace;
    if !(-dot(d, l.n) > MIN_COS) {
        t.outcome = OUTCOME_FALLBACK;
        return t;
    }
    let max_lenses = clamp(max_lenses_in, 1u, MAX_EXACT_LENSES);
    var o = p;
    var dir = d;
    var transmittance = 1.0;
    var count = 0u;
    var last = vec2<f32>(0.0);
    for (var guard = 0u; guard < MAX_EXACT_LENSES; guard++) {
        if count >= max_lenses {
            break;
        }
        let w = walk_first_lens(l, o, dir, last, count > 0u);
        if w.status == WALK_LIMIT {
            t.outcome = OUTCOME_FALLBACK;
            return t;
        }
        if w.status == WALK_NONE {
            break;
        }
        let out = refract_through_ball(o + w.t * dir, dir, w.centre, l);
        if !out.ok {
            t.outcome = OUTCOME_FALLBACK;
            return t;
        }
        o = out.exit;
        dir = out.dir;
        transmittance *= out.transmittance;
        count += 1u;
        last = w.index;
    }
    return finish(l, o, dir, count, transmittance);
}

// pigment.rs `smoothstep` is WGSL's own; `DarkCentre::transmission`.
fn dark_centre(kind: u32, t: vec2<f32>, radius: f32, softness: f32, darkness: f32) -> f32 {
    let rho = length(t - cell_of(kind, t).centre_uv);
    var clear = select(0.0, 1.0, rho >= radius);
    if softness > 0.0 {
        clear = smoothstep(radius - softness, radius + softness, rho);
    }
    return 1.0 - darkness * (1.0 - clear);
}
