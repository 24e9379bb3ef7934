// The compound-eye material: StandardMaterial's fragment shader with
// Sagawa's lens lattice (thesis ch. 6) between the surface and its colour.
// The optics are in `compound_eye_optics.wgsl`, the twin of
// `optica_optics::compound_eye`.

#import bevy_pbr::{
    pbr_fragment::pbr_input_from_standard_material,
    pbr_functions::alpha_discard,
    pbr_types::{PbrInput, STANDARD_MATERIAL_FLAGS_UNLIT_BIT},
}
#ifdef PREPASS_PIPELINE
// The deferred renderer's G-buffer pass: the lattice changes the material
// the G-buffer holds, and Bevy's lighting pass lights it.
#import bevy_pbr::{
    prepass_io::{VertexOutput, FragmentOutput},
    pbr_deferred_functions::deferred_output,
}
#else
#import bevy_pbr::{
    pbr_functions::{apply_pbr_lighting, main_pass_post_lighting_processing},
    forward_io::{VertexOutput, FragmentOutput},
}
#endif
#import optica::compound_eye as eye

struct CompoundEyeUniform {
    facets_per_uv: f32,
    lens_radius: f32,
    lens_index: f32,
    pigment_depth: f32,
    dark_radius: f32,
    dark_softness: f32,
    darkness: f32,
    slices: u32,
    pigment_scale: vec2<f32>,
    pigment_offset: vec2<f32>,
    max_lenses: u32,
    flags: u32,
}

// settings.rs `mod flags`.
const FLAG_ENABLED: u32 = 1u;
const FLAG_HEXAGONAL: u32 = 2u;
const FLAG_FRESNEL: u32 = 4u;
const FLAG_PREFILTER: u32 = 8u;
const FLAG_TEXTURE: u32 = 16u;
const FLAG_PIGMENT_ONLY: u32 = 32u;
const FLAG_EXACT: u32 = 64u;
const FLAG_TABLE: u32 = 128u;
const FLAG_TANGENT_AXES: u32 = 256u;
const FLAG_AXIS_FIELD: u32 = 512u;

// texture_axes.rs UV_DET_REL_EPS for f32 derivatives: a triangle whose
// facet-coordinate gradients (or world axes U, V) are closer to parallel than
// this (the sine of their angle) has no lattice.
const UV_DET_REL_EPS: f32 = 1e-4;

// pigment.rs PREFILTER_OFFSETS: a 3×3 stratified pattern.
const PREFILTER_SAMPLES: u32 = 9u;

@group(#{MATERIAL_BIND_GROUP}) @binding(100) var<uniform> material: CompoundEyeUniform;
@group(#{MATERIAL_BIND_GROUP}) @binding(101) var pigment_texture: texture_2d<f32>;
@group(#{MATERIAL_BIND_GROUP}) @binding(102) var pigment_sampler: sampler;
@group(#{MATERIAL_BIND_GROUP}) @binding(103) var prefilter_table: texture_2d<f32>;

// prefilter_table.rs TABLE_AZIMUTHS and TABLE_POLARS.
const TABLE_AZIMUTHS: i32 = 16;
const TABLE_POLARS: i32 = 32;

// prefilter_table.rs `PrefilterTable::sample`: the facet average for a ray
// along `d` into the lattice `l`, bilinear between texel centres (read by
// hand: the float texture is not filterable everywhere), repeating in
// azimuth, clamped in the polar angle. Returns (mean factor, escape share,
// mean escape direction in world space).
struct TableSample {
    multiplier: f32,
    escape: f32,
    escape_dir: vec3<f32>,
}

fn table_texel(i: i32, j: i32) -> vec4<f32> {
    let x = ((i % TABLE_AZIMUTHS) + TABLE_AZIMUTHS) % TABLE_AZIMUTHS;
    return textureLoad(prefilter_table, vec2<i32>(x, clamp(j, 0, TABLE_POLARS - 1)), 0);
}

fn table_sample(l: eye::Lattice, d: vec3<f32>) -> TableSample {
    let u_hat = normalize(l.u);
    let w_hat = normalize(l.v - dot(l.v, u_hat) * u_hat);
    let polar = acos(clamp(-dot(d, l.n), -1.0, 1.0));
    let azimuth = atan2(dot(d, w_hat), dot(d, u_hat));
    var period = 1.5707964;
    if l.kind == eye::KIND_HEXAGONAL {
        period = 1.0471976;
    }
    let x = azimuth / period * f32(TABLE_AZIMUTHS) - 0.5;
    let y = clamp(polar / 1.5707964 * f32(TABLE_POLARS) - 0.5, 0.0, f32(TABLE_POLARS - 1));
    let x0 = floor(x);
    let y0 = floor(y);
    let f = vec2<f32>(x - x0, y - y0);
    let i = i32(x0);
    let j = i32(y0);
    let v = mix(mix(table_texel(i, j), table_texel(i + 1, j), f.x),
        mix(table_texel(i, j + 1), table_texel(i + 1, j + 1), f.x), f.y);
    let tangent = v.z * u_hat + v.w * w_hat;
    let up = sqrt(max(1.0 - dot(tangent, tangent), 0.0));
    var s: TableSample;
    s.multiplier = v.x;
    s.escape = v.y;
    let dir = tangent + up * l.n;
    s.escape_dir = select(vec3<f32>(0.0), normalize(dir), dot(dir, dir) > 0.0);
    return s;
}

struct Response {
    multiplier: f32,
    escape_weight: f32,
    escape_dir: vec3<f32>,
    lenses: u32,
}

// The pigment's c_t at the local pigment coordinate `t` (facets, relative to
// the fragment's lattice origin shifted by `shift`): the texture if the
// material has one (greyscale, red channel, its own UV scale and offset), the
// procedural dark centre otherwise.
fn pigment_transmission(kind: u32, t: vec2<f32>, shift: vec2<f32>, lod: f32) -> f32 {
    if (material.flags & FLAG_TEXTURE) != 0u {
        let st = (t + shift) * material.pigment_scale + material.pigment_offset;
        return textureSampleLevel(pigment_texture, pigment_sampler, st, lod).r;
    }
    return eye::dark_centre(kind, t, material.dark_radius, material.dark_softness, material.darkness);
}

// pigment.rs `facet_response`.
fn facet_response(l: eye::Lattice, p: vec3<f32>, d: vec3<f32>, shift: vec2<f32>, lod: f32) -> Response {
    var r: Response;
    r.multiplier = 1.0;
    r.escape_weight = 0.0;
    var trace: eye::Trace;
    if (material.flags & FLAG_EXACT) != 0u {
        trace = eye::shade_exact(l, p, d, material.max_lenses);
    } else {
        trace = eye::shade_fragment(l, p, d, material.slices, material.max_lenses);
    }
    r.lenses = trace.lenses;
    if trace.outcome == eye::OUTCOME_PIGMENT {
        var transmittance = 1.0;
        if (material.flags & FLAG_FRESNEL) != 0u {
            transmittance = trace.transmittance;
        }
        r.multiplier = pigment_transmission(l.kind, trace.uv, shift, lod) * transmittance;
    } else if trace.outcome == eye::OUTCOME_ESCAPED {
        r.escape_weight = 1.0;
        r.escape_dir = trace.dir;
    }
    return r;
}

// The lattice's response at the fragment seen along `-view` with the
// mesh's interpolated normal `normal`: c_t·T, or the weight and direction
// of a ray that leaves the eye. Called in uniform control flow (it takes
// derivatives).
fn lattice_response(in: VertexOutput, view: vec3<f32>, normal: vec3<f32>) -> Response {
    var response: Response;
    response.multiplier = 1.0;
    response.escape_weight = 0.0;
#ifdef VERTEX_UVS_A
    // The lattice's texture axes U_p, V_p (eq. 6.8–6.15) are the triangle's
    // ∂P/∂t, recovered exactly from the screen-space derivatives of the
    // interpolated position and facet coordinate: both are affine in the
    // triangle's barycentrics, so J_P = U·J_t and U = J_P·J_t⁻¹.
    let facet = in.uv * material.facets_per_uv; // (6.1)
    let dpx = dpdx(in.world_position.xyz);
    let dpy = dpdy(in.world_position.xyz);
    let dtx = dpdx(facet);
    let dty = dpdy(facet);
    let det = dtx.x * dty.y - dty.x * dtx.y;
    let footprint = max(length(dtx), length(dty)); // facets per pixel
    let texels = vec2<f32>(textureDimensions(pigment_texture));
    let texel_rate = abs(material.pigment_scale) * texels; // texels per facet
    let lod = log2(max(footprint * max(texel_rate.x, texel_rate.y), 1.0));

    // U and V in world units per facet. The trace is scale-free (every
    // length is a multiple of the cell), so it runs in a frame scaled to a
    // facet of about one unit: f32 keeps its precision and |U|⁴ neither
    // underflows nor overflows, whether a facet is 1e-9 or 1e9 units.
    var u = (dpx * dty.y - dpy * dtx.y) / det;
    var v = (dpy * dtx.x - dpx * dty.x) / det;
    let scale = max(length(u), length(v));
    u /= scale;
    v /= scale;
    let frame_ok = scale > 0.0 && scale < 3.0e38 && length(cross(u, v)) > UV_DET_REL_EPS;
    if (material.flags & FLAG_ENABLED) != 0u && abs(det) > UV_DET_REL_EPS * length(dtx) * length(dty) && frame_ok {
        var n = normalize(cross(u, v));
        // Lenses lie on the far side from the viewer.
        if dot(n, view) < 0.0 {
            n = -n;
        }
        // texture_axes.rs `TextureAxes::on_normal`: the lattice lies in the
        // plane of the interpolated normal, not the triangle's, so that it
        // bends with the surface and a coarse mesh shows no seams at its
        // edges (the axes are continuous across an edge in that plane).
        let curved = eye::axes_on_normal(u, v, n, normal);
        u = curved[0];
        v = curved[1];
        n = curved[2];
#ifdef VERTEX_TANGENTS
        // texture_axes.rs `TextureAxes::on_tangent`: along the interpolated
        // tangent frame, continuous across triangle edges.
        if (material.flags & FLAG_TANGENT_AXES) != 0u {
            let along = eye::axes_on_tangent(u, v, n, in.world_tangent.xyz);
            u = along[0];
            v = along[1];
        }
#ifdef VERTEX_UVS_B
        // texture_axes.rs `TextureAxes::on_field`: along the smooth axis
        // field `insert_axis_field` put in the tangents and second UVs.
        // (After the tangent frame it gives the same axes: that frame
        // keeps the cell's area and its axes' sides.)
        if (material.flags & FLAG_AXIS_FIELD) != 0u {
            let along = eye::axes_on_field(u, v, n, in.world_tangent.xyz, in.uv_b);
            u = along[0];
            v = along[1];
        }
#endif
#endif
        var kind = eye::KIND_SQUARE;
        if (material.flags & FLAG_HEXAGONAL) != 0u {
            kind = eye::KIND_HEXAGONAL;
        }
        // Local facet coordinates: shifted by a lattice vector so that the
        // numbers stay small whatever R_t is (the lattice is periodic).
        var shift = floor(facet);
        if kind == eye::KIND_HEXAGONAL {
            let j = floor(facet.y / eye::ROW);
            let q = floor(facet.x - 0.5 * facet.y / eye::ROW);
            shift = eye::centre_of_index(kind, vec2<f32>(q, j));
        }
        let t = facet - shift;
        // The fragment is the origin: P_c = −(a U + b V) (eq. 6.3 with P_e = P).
        var l = eye::make_lattice(-(t.x * u + t.y * v), u, v, n, kind);
        l.r = material.lens_radius * eye::cell_inradius(kind, u, v);
        l.index = material.lens_index;
        l.depth = material.pigment_depth * l.r;
        let d = -view;
        // pigment.rs `facet_response_prefiltered`: the fragment's own ray,
        // blended by `w` into the facet average. Where the average replaces
        // it entirely (`w = 1`), the own ray is not traced (its lens count
        // in the optics-only output is then 0).
        var w = 0.0;
        if (material.flags & FLAG_PREFILTER) != 0u {
            w = smoothstep(eye::PREFILTER_START, eye::PREFILTER_FULL, footprint);
        }
        let tabled = (material.flags & FLAG_TABLE) != 0u && (material.flags & FLAG_TEXTURE) == 0u;
        // One loop, one call site of the trace: ray 0 is the fragment's
        // own (unless the average replaces it), rays 1–9 the nine-ray
        // average where there is no table. (SIMD rasterisers run a call
        // site's code even where no lane takes it; lavapipe does.)
        let centre = eye::cell_of(kind, t).centre_uv;
        var sum = 0.0;
        let first = select(1u, 0u, w < 1.0);
        let end = select(1u, 1u + PREFILTER_SAMPLES, w > 0.0 && !tabled);
        for (var i = first; i < end; i++) {
            var q = vec3<f32>(0.0);
            if i > 0u {
                let offset = vec2<f32>(f32((i - 1u) % 3u) - 1.0, f32((i - 1u) / 3u) - 1.0) / 3.0;
                q = eye::point_of(l, centre + offset);
            }
            let r = facet_response(l, q, d, shift, lod);
            if i == 0u {
                response = r;
            } else {
                sum += r.multiplier;
            }
        }
        if w > 0.0 && tabled {
            // pigment.rs `facet_response_tabled`.
            let s = table_sample(l, d);
            if response.escape_weight == 0.0 {
                response.escape_dir = s.escape_dir;
            }
            response.multiplier = mix(response.multiplier, s.multiplier, w);
            response.escape_weight = mix(response.escape_weight, s.escape, w);
        } else if w > 0.0 {
            response.multiplier = mix(response.multiplier, sum / f32(PREFILTER_SAMPLES), w);
            response.escape_weight *= 1.0 - w;
        }
    }
#endif
    return response;
}

// What an escaping ray sees: the surface as a mirror whose reflection
// points along the ray, i.e. the view's environment map (or ambient light
// and light highlights without one).
fn as_mirror(pbr_input: PbrInput, escape_dir: vec3<f32>) -> PbrInput {
    var mirror = pbr_input;
    mirror.material.base_color = vec4<f32>(vec3<f32>(1.0), pbr_input.material.base_color.a);
    mirror.material.metallic = 1.0;
    mirror.material.perceptual_roughness = 0.089;
    mirror.material.emissive = vec4<f32>(0.0);
    // What lies beyond the eye is seen whatever the base material's
    // lighting: an unlit eye's escaping rays show it lit too.
    mirror.material.flags &= ~STANDARD_MATERIAL_FLAGS_UNLIT_BIT;
    mirror.N = normalize(pbr_input.V + escape_dir);
    return mirror;
}

// Whether the pixel shows the mirror: with the probability of the escape
// weight, by a fixed dither (interleaved gradient noise, Jimenez 2014).
fn shows_mirror(response: Response, pixel: vec2<f32>) -> bool {
    let f = floor(pixel);
    let threshold = fract(52.9829189 * fract(dot(f, vec2<f32>(0.06711056, 0.00583715))));
    return threshold < response.escape_weight;
}

// What the pixel shows: the lattice's material, or the mirror where its ray
// escapes. Where the prefilter leaves a share 0 < w < 1 of escaping rays,
// the pixel shows the mirror with probability w, by a fixed dither
// (interleaved gradient noise, Jimenez 2014), so that it is lit once:
// mixing the two lit colours takes a second lighting call, which costs
// 0.4× a plain material on lavapipe even where no pixel escapes (it runs
// the code of every branch), and mixing the two materials' parameters
// lights one broad highlight where the mirror's sparse sparkles are (in
// the report's sub-pixel case, ꟻLIP 0.16 against the supersampled render,
// against 0.054 dithered and 0.053 for mixed colours). The G-buffer holds
// one material a pixel in any case.
fn shown_material(lattice: PbrInput, pbr_input: PbrInput, response: Response, mirror: bool) -> PbrInput {
    if mirror {
        return as_mirror(pbr_input, response.escape_dir);
    }
    return lattice;
}

// The optics alone, unlit: c_t·T, the environment weight, lenses/4.
fn optics_colour(response: Response) -> vec4<f32> {
    return vec4<f32>(response.multiplier, response.escape_weight, f32(response.lenses) / 4.0, 1.0);
}

@fragment
fn fragment(in: VertexOutput, @builtin(front_facing) is_front: bool) -> FragmentOutput {
    var pbr_input = pbr_input_from_standard_material(in, is_front);
    pbr_input.material.base_color = alpha_discard(pbr_input.material, pbr_input.material.base_color);
    let response = lattice_response(in, pbr_input.V, pbr_input.world_normal);
    let unlit = (pbr_input.material.flags & STANDARD_MATERIAL_FLAGS_UNLIT_BIT) != 0u;
    // Eq. 6.30, c = c_t (a + d) + s: c_t scales the colour that diffuse and
    // ambient light act on; Bevy's specular term is left as it is. Unlit,
    // c_t scales the base colour shown as it is.
    var lattice = pbr_input;
    lattice.material.base_color = vec4<f32>(pbr_input.material.base_color.rgb * response.multiplier,
        pbr_input.material.base_color.a);

#ifdef PREPASS_PIPELINE
    if (material.flags & FLAG_PIGMENT_ONLY) != 0u {
        lattice.material.base_color = optics_colour(response);
        lattice.material.flags |= STANDARD_MATERIAL_FLAGS_UNLIT_BIT;
    } else {
        // Unlit, the lattice stays unlit and an escaping ray's mirror is lit.
        lattice = shown_material(lattice, pbr_input, response, shows_mirror(response, in.position.xy));
    }
    return deferred_output(in, lattice);
#else
    var out: FragmentOutput;
    if (material.flags & FLAG_PIGMENT_ONLY) != 0u {
        out.color = optics_colour(response);
        return out;
    }
    // Unlit, the lattice shows its colour as it is, and an escaping ray
    // what lies beyond, lit, as in a lit eye (one lighting call site).
    let mirror = shows_mirror(response, in.position.xy);
    if unlit && !mirror {
        out.color = lattice.material.base_color;
    } else {
        out.color = apply_pbr_lighting(shown_material(lattice, pbr_input, response, mirror));
    }
    out.color = main_pass_post_lighting_processing(pbr_input, out.color);
    return out;
#endif
}
