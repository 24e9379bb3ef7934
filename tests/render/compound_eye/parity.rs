//! The shader's optics against the CPU twin, pixel by pixel: a flat quad
//! with a known lattice, seen by a tilted orthographic camera, drawn with
//! `EyeOutput::PigmentOnly` into an HDR target; every pixel's factor on the
//! surface colour, environment weight and lens count are compared with
//! `optica_optics::compound_eye::facet_response` for the ray through the
//! pixel's centre.
//!
//! Stated tolerance: the shader is f32 and the readback f16, so a smooth
//! value agrees to ~1e-3; a pixel whose centre lies within round-off of a
//! lens rim or a cell edge may take the other branch. So: at least 98 % of
//! the quad's pixels within 0.02, and the mean difference below 0.01.

use bevy::mesh::{Indices, VertexAttributeValues};
use bevy::prelude::*;
use optica_compound_eye::{CompoundEye, EyeLattice, EyeOutput};
use optica_harness::Headless;
use optica_optics::compound_eye::{
    DarkCentre, Lattice, LensParams, MAX_EXACT_LENSES, PrefilterTable, Ray, ShadeOptions,
    TextureAxes, facet_response, facet_response_tabled,
};
use optica_optics::glam::{DVec2, DVec3};

use super::{ortho, scene};

const SIZE: u32 = 96;
const VIEW_SPAN: f32 = 2.4;

/// The direction the camera looks in: about 35° off the quad's normal, not
/// along a lattice axis.
fn view_dir() -> Vec3 {
    Vec3::new(-0.6, -0.35, -1.0).normalize()
}

fn camera(dir: Vec3) -> Transform {
    Transform::from_translation(-5.0 * dir).looking_to(dir, Vec3::Y)
}

/// The quad, its CPU lattice for `eye`, and the CPU ray through each pixel.
struct Setup {
    lattice: Lattice,
    options: ShadeOptions,
    pigment: DarkCentre,
    fresnel: bool,
    /// `CompoundEye::lens_radius` and the lens's index and depth.
    lens: (f64, f64, f64),
}

impl Setup {
    /// The lattice the shader builds at `at` with the mesh's normal
    /// `shading`: the axes laid on it, the lens sized to their cell.
    fn on_normal(
        &self,
        at: DVec3,
        shading: DVec3,
        tangent: Option<DVec3>,
        shape: Option<DVec2>,
    ) -> Lattice {
        let mut axes = self.lattice.axes().on_normal(at, shading);
        match (tangent, shape) {
            (Some(t), Some(s)) => axes = axes.on_field(at, t, s),
            (Some(t), None) => axes = axes.on_tangent(at, t),
            _ => {}
        }
        let kind = self.lattice.kind();
        let (radius, index, depth) = self.lens;
        let r = radius * kind.cell_inradius(axes.u(), axes.v());
        let lens = LensParams::new(r, index, depth * r).expect("valid lens");
        Lattice::with_kind(axes, lens, kind).unwrap()
    }
}

fn cpu_setup(eye: &CompoundEye, quad: &Mesh) -> Setup {
    let Some(VertexAttributeValues::Float32x3(p)) = quad.attribute(Mesh::ATTRIBUTE_POSITION) else {
        panic!("positions")
    };
    let Some(VertexAttributeValues::Float32x2(uv)) = quad.attribute(Mesh::ATTRIBUTE_UV_0) else {
        panic!("uvs")
    };
    let Some(Indices::U32(idx)) = quad.indices() else {
        panic!("u32 indices")
    };
    let corner = |k: usize| {
        let i = idx[k] as usize;
        (
            DVec3::from(p[i].map(f64::from)),
            DVec2::from(uv[i].map(f64::from)) * eye.facets_per_uv as f64,
        )
    };
    let (a, b, c) = (corner(0), corner(1), corner(2));
    let axes =
        TextureAxes::from_triangle([a.0, b.0, c.0], [a.1, b.1, c.1]).expect("a regular quad");
    let kind = eye.lattice_kind();
    let r = eye.lens_radius as f64 * kind.cell_inradius(axes.u(), axes.v());
    let lens = LensParams::new(r, eye.lens_index as f64, eye.pigment_depth as f64 * r)
        .expect("valid lens");
    let pigment = DarkCentre::new(
        eye.pigment.radius as f64,
        eye.pigment.softness as f64,
        eye.pigment.darkness as f64,
    )
    .unwrap();
    let options = match (eye.exact, eye.follow_neighbours) {
        (true, true) => ShadeOptions::exact(MAX_EXACT_LENSES),
        (true, false) => ShadeOptions::exact(1),
        (false, true) => ShadeOptions::neighbours(eye.slices),
        (false, false) => ShadeOptions::thesis(eye.slices),
    };
    Setup {
        lattice: Lattice::with_kind(axes, lens, kind).unwrap(),
        options,
        pigment,
        fresnel: eye.fresnel,
        lens: (
            eye.lens_radius as f64,
            eye.lens_index as f64,
            eye.pigment_depth as f64,
        ),
    }
}

/// The CPU ray through the centre of pixel (i, j), where it meets the quad
/// (z = 0), if inside it with a margin of two pixels.
fn cpu_fragment(i: u32, j: u32, view: Vec3) -> Option<Ray> {
    let cam = camera(view);
    let px = VIEW_SPAN / SIZE as f32;
    let x = ((i as f32 + 0.5) / SIZE as f32 - 0.5) * VIEW_SPAN;
    let y = (0.5 - (j as f32 + 0.5) / SIZE as f32) * VIEW_SPAN;
    let origin = (cam.translation + cam.right() * x + cam.up() * y).as_dvec3();
    let dir = view.as_dvec3();
    let p = origin + dir * (-origin.z / dir.z);
    let margin = 1.0 - 2.0 * px as f64 / view.z.abs() as f64;
    (p.x.abs() < margin && p.y.abs() < margin).then(|| Ray::new(p, dir).unwrap())
}

struct Agreement {
    pixels: usize,
    within: f64,
    mean: f64,
    /// `None` with the prefilter on (no own ray to count).
    lens_count_agree: Option<f64>,
    escaping: usize,
    /// Pixels whose outcome (escaping or not) is the CPU's.
    same_outcome: usize,
}

/// The plain quad, its UVs as Bevy makes them.
fn quad() -> Mesh {
    Mesh::from(Rectangle::new(2.0, 2.0))
}

/// `compare_on` the plain quad, without the prefilter.
fn compare(eye: CompoundEye) -> Agreement {
    compare_on(
        quad(),
        CompoundEye {
            prefilter: false,
            ..eye
        },
    )
}

/// The facet footprint of pixel (i, j), in facets per pixel, as the shader
/// takes it from its derivatives: the larger of the facet-coordinate steps
/// to the next pixel right and down.
fn footprint(axes: &TextureAxes, i: u32, j: u32, view: Vec3) -> Option<f64> {
    let at = |i, j| cpu_fragment(i, j, view).map(|r| axes.uv_of(r.origin()));
    let here = at(i, j)?;
    Some(
        (at(i + 1, j)? - here)
            .length()
            .max((at(i, j + 1)? - here).length()),
    )
}

fn compare_on(quad: Mesh, eye: CompoundEye) -> Agreement {
    compare_on_normal(quad, eye, None, None, None, true, view_dir())
}

/// `compare_on` with every vertex normal of `quad` set to `shading` (its
/// tangent to `tangent`, its axis field's shape, the second UVs, to
/// `shape`) when given; the CPU lattice is laid on them, pixel by pixel,
/// when `cpu_follows` (the GPU follows the tangent only with
/// `tangent_axes` or `axis_field`, the shape only with `axis_field`).
fn compare_on_normal(
    mut quad: Mesh,
    eye: CompoundEye,
    shading: Option<Vec3>,
    tangent: Option<Vec4>,
    shape: Option<Vec2>,
    cpu_follows: bool,
    view: Vec3,
) -> Agreement {
    let count = quad.count_vertices();
    if let Some(m) = shading {
        quad.insert_attribute(Mesh::ATTRIBUTE_NORMAL, vec![m.to_array(); count]);
    }
    if let Some(t) = tangent {
        quad.insert_attribute(Mesh::ATTRIBUTE_TANGENT, vec![t.to_array(); count]);
    }
    if let Some(s) = shape {
        quad.insert_attribute(Mesh::ATTRIBUTE_UV_1, vec![s.to_array(); count]);
    }
    let cpu_tangent = tangent.map(|t| t.truncate().as_dvec3());
    let cpu_shape = shape.map(|s| s.as_dvec2());
    let eye = CompoundEye {
        output: EyeOutput::PigmentOnly,
        ..eye
    };
    let setup = cpu_setup(&eye, &quad);
    let prefilter = eye.prefilter;
    // The plugin's table for these settings, made the same way.
    let table = prefilter.then(|| {
        PrefilterTable::build(
            eye.lattice_kind(),
            eye.lens_radius as f64,
            eye.lens_index as f64,
            eye.pigment_depth as f64,
            &setup.pigment,
            eye.fresnel,
            &setup.options,
        )
        .expect("a table")
    });
    let frame = Headless::new(SIZE, SIZE)
        .hdr(true)
        .render(scene(
            quad,
            Transform::IDENTITY,
            Some(eye),
            camera(view),
            ortho(VIEW_SPAN),
        ))
        .expect("render");
    let gpu = frame.hdr().expect("an HDR frame");
    let (mut n, mut within, mut sum, mut escaping) = (0usize, 0usize, 0.0, 0usize);
    let mut same_outcome = 0usize;
    let (mut hits, mut counts) = (0usize, 0usize);
    for j in 0..SIZE {
        for i in 0..SIZE {
            let Some(ray) = cpu_fragment(i, j, view) else {
                continue;
            };
            let on_normal;
            let lattice = match shading.filter(|_| cpu_follows) {
                Some(m) => {
                    on_normal = setup.on_normal(ray.origin(), m.as_dvec3(), cpu_tangent, cpu_shape);
                    &on_normal
                }
                None => &setup.lattice,
            };
            let cpu = if let Some(table) = &table {
                let Some(footprint) = footprint(lattice.axes(), i, j, view) else {
                    continue;
                };
                facet_response_tabled(
                    lattice,
                    &ray,
                    &setup.options,
                    &setup.pigment,
                    setup.fresnel,
                    footprint,
                    table,
                )
            } else {
                facet_response(lattice, &ray, &setup.options, &setup.pigment, setup.fresnel)
            };
            let [m, e, lenses, _] = gpu.get_pixel(i, j).0;
            let cpu_e = cpu.escape.map_or(0.0, |(_, w)| w);
            let d = (m as f64 - cpu.multiplier)
                .abs()
                .max((e as f64 - cpu_e).abs());
            n += 1;
            sum += d;
            within += usize::from(d <= 0.02);
            escaping += usize::from(cpu_e > 0.0);
            same_outcome += usize::from((cpu_e > 0.0) == (e > 0.5));
            // The lens count of the rays that reach the pigment (the shader
            // writes the count of the fragment's own ray, not the average).
            // Where the prefilter takes over, the shader skips that ray.
            if prefilter {
                continue;
            }
            if let Some(hit) =
                optica_optics::compound_eye::shade_fragment_with(lattice, &ray, &setup.options)
                    .hit()
            {
                hits += 1;
                counts += usize::from((lenses - hit.lenses as f32 / 4.0).abs() < 0.01);
            }
        }
    }
    Agreement {
        pixels: n,
        within: within as f64 / n as f64,
        mean: sum / n as f64,
        lens_count_agree: (hits > 0).then(|| counts as f64 / hits as f64),
        escaping,
        same_outcome,
    }
}

fn assert_agrees(name: &str, a: &Agreement) {
    eprintln!(
        "{name}: {} px, {:.2} % within 0.02, mean |Δ| {:.5}, lens count agrees on {:?}, {} escaping",
        a.pixels,
        100.0 * a.within,
        a.mean,
        a.lens_count_agree,
        a.escaping
    );
    assert!(
        a.pixels > 3000,
        "{name}: only {} pixels on the quad",
        a.pixels
    );
    assert!(
        a.within >= 0.98 && a.mean < 0.01,
        "{name}: {:.4} within 0.02, mean {:.5}",
        a.within,
        a.mean
    );
    if let Some(agree) = a.lens_count_agree {
        assert!(agree >= 0.98, "{name}: lens counts agree on {agree:.4}");
    }
}

#[test]
fn thesis_path_matches_its_cpu_twin() {
    let a = compare(CompoundEye::thesis(8.0, 1.5, 8));
    assert_agrees("square, one lens", &a);
}

#[test]
fn hexagonal_lattice_with_neighbours_and_fresnel_matches_its_cpu_twin() {
    let eye = CompoundEye {
        facets_per_uv: 7.0,
        lattice: EyeLattice::Hexagonal,
        slices: 12,
        ..default()
    };
    let a = compare(eye);
    assert_agrees("hexagonal, neighbours, Fresnel", &a);
}

#[test]
fn low_index_lenses_send_rays_back_out_on_the_cpu_and_the_gpu_alike() {
    // n = 0.8 bends rays away from the axis; steep ones leave the eye again,
    // and the shader must report the same escapes as the twin.
    let eye = CompoundEye {
        lens_index: 0.8,
        pigment_depth: 2.0,
        ..CompoundEye::thesis(8.0, 0.8, 16)
    };
    let a = compare(eye);
    assert_agrees("n = 0.8", &a);
    assert!(a.escaping > 0, "no ray escaped: the case tests nothing");
}

/// Mirrored, sheared and stretched UVs (one affine map over the quad): the
/// derivative-built axes are the CPU's `TextureAxes::from_triangle`.
#[test]
fn mirrored_and_sheared_uvs_match_the_cpu_axes() {
    let mut mesh = quad();
    if let Some(VertexAttributeValues::Float32x2(uv)) = mesh.attribute_mut(Mesh::ATTRIBUTE_UV_0) {
        for t in uv.iter_mut() {
            *t = [-1.3 * t[0] + 0.4 * t[1], 0.8 * t[1] + 0.1 * t[0]];
        }
    }
    let eye = CompoundEye {
        facets_per_uv: 7.0,
        lattice: EyeLattice::Hexagonal,
        slices: 12,
        prefilter: false,
        ..default()
    };
    let a = compare_on(mesh, eye);
    assert_agrees("hexagonal, mirrored and sheared UVs", &a);
}

/// Facets well below a pixel: the shader's prefilter (the facet average
/// read from the plugin's table, blended in by the footprint) against
/// `facet_response_tabled` with a table built on the CPU.
#[test]
fn prefiltered_small_facets_match_their_cpu_twin() {
    let eye = CompoundEye {
        facets_per_uv: 120.0,
        lattice: EyeLattice::Hexagonal,
        slices: 12,
        prefilter: true,
        ..default()
    };
    let a = compare_on(quad(), eye);
    assert_agrees("prefiltered, 1.5–1.9 facets per pixel", &a);
}

/// A quad whose vertex normals lean 20° off its plane (as a curved mesh's
/// interpolated normal does): the shader lays the lattice on that normal,
/// as `TextureAxes::on_normal` does.
#[test]
fn lattice_on_a_leaning_vertex_normal_matches_its_cpu_twin() {
    let eye = CompoundEye {
        facets_per_uv: 7.0,
        lattice: EyeLattice::Hexagonal,
        slices: 12,
        prefilter: false,
        ..default()
    };
    let leaning = Vec3::new(0.28, -0.21, 1.0).normalize();
    let a = compare_on_normal(
        quad(),
        eye.clone(),
        Some(leaning),
        None,
        None,
        true,
        view_dir(),
    );
    assert_agrees("hexagonal, leaning normal", &a);
    // The lean matters: against the triangle's own lattice the render is
    // far off.
    let flat = compare_on_normal(quad(), eye, Some(leaning), None, None, false, view_dir());
    eprintln!(
        "against the flat lattice: {:.2} % within 0.02, mean {:.4}",
        100.0 * flat.within,
        flat.mean
    );
    assert!(flat.within < 0.9, "{:.4} within 0.02", flat.within);
}

/// The quad with sheared, stretched and mirrored UVs.
fn sheared_quad() -> Mesh {
    let mut mesh = quad();
    if let Some(VertexAttributeValues::Float32x2(uv)) = mesh.attribute_mut(Mesh::ATTRIBUTE_UV_0) {
        for t in uv.iter_mut() {
            *t = [-1.3 * t[0] + 0.4 * t[1], 0.8 * t[1] + 0.1 * t[0]];
        }
    }
    mesh
}

/// Sheared, stretched and mirrored UVs on a quad with a leaning normal and
/// a tangent 30° off its u axis: with `tangent_axes` the shader lays square
/// facets of the UVs' cell area along the tangent, as
/// `TextureAxes::on_tangent` does.
#[test]
fn lattice_along_the_tangent_matches_its_cpu_twin() {
    let sheared = sheared_quad;
    let eye = CompoundEye {
        facets_per_uv: 7.0,
        lattice: EyeLattice::Hexagonal,
        tangent_axes: true,
        prefilter: false,
        ..default()
    };
    let leaning = Vec3::new(0.28, -0.21, 1.0).normalize();
    let tangent = Vec4::new(30f32.to_radians().cos(), 30f32.to_radians().sin(), 0.0, 1.0);
    let a = compare_on_normal(
        sheared(),
        eye.clone(),
        Some(leaning),
        Some(tangent),
        None,
        true,
        view_dir(),
    );
    assert_agrees("hexagonal along a tangent", &a);
    // The tangent matters: the UVs' own axes (on the same normal) are far
    // from the tangent's lattice.
    let uv_axes = CompoundEye {
        tangent_axes: false,
        ..eye
    };
    let b = compare_on_normal(
        sheared(),
        uv_axes,
        Some(leaning),
        Some(tangent),
        None,
        true,
        view_dir(),
    );
    eprintln!(
        "the UVs' axes against the tangent's: {:.2} % within 0.02, mean {:.4}",
        100.0 * b.within,
        b.mean
    );
    assert!(b.within < 0.9, "{:.4} within 0.02", b.within);
}

/// Sheared, stretched and mirrored UVs on a quad with a leaning normal,
/// and an axis field 30° off the u axis with its own stretch and shear:
/// with `axis_field` the shader lays the lattice along the field, as
/// `TextureAxes::on_field` does (the square tangent frame is far from it).
#[test]
fn lattice_along_an_axis_field_matches_its_cpu_twin() {
    let eye = CompoundEye {
        facets_per_uv: 7.0,
        lattice: EyeLattice::Hexagonal,
        axis_field: true,
        prefilter: false,
        ..default()
    };
    let leaning = Vec3::new(0.28, -0.21, 1.0).normalize();
    let tangent = Vec4::new(30f32.to_radians().cos(), 30f32.to_radians().sin(), 0.0, 1.0);
    let shape = Vec2::new(0.35, 1.6);
    let a = compare_on_normal(
        sheared_quad(),
        eye.clone(),
        Some(leaning),
        Some(tangent),
        Some(shape),
        true,
        view_dir(),
    );
    assert_agrees("hexagonal along an axis field", &a);
    let square = CompoundEye {
        axis_field: false,
        tangent_axes: true,
        ..eye
    };
    let b = compare_on_normal(
        sheared_quad(),
        square,
        Some(leaning),
        Some(tangent),
        Some(shape),
        true,
        view_dir(),
    );
    eprintln!(
        "the tangent frame against the field: {:.2} % within 0.02, mean {:.4}",
        100.0 * b.within,
        b.mean
    );
    assert!(b.within < 0.9, "{:.4} within 0.02", b.within);
}

/// The default exact path against the exact tracer (`trace_exact` with the
/// shader's walk cap), by incidence band: a flat lattice seen from 0° to
/// 80° off its normal, square and hexagonal, lens index 1.33 to 1.7, rays
/// followed through up to 16 lenses. Goal: the outcome (pigment or
/// escape) agrees on at least 99.5 % of pixels and the value within 0.02
/// on at least 99 %, in every band.
#[test]
fn the_exact_path_matches_the_exact_tracer_at_every_incidence() {
    let bands: [(&str, &[f32]); 3] = [
        ("0–30°", &[0.0, 25.0]),
        ("30–60°", &[45.0, 60.0]),
        ("60–80°", &[70.0, 80.0]),
    ];
    let lattices = [
        (EyeLattice::Square, 1.33),
        (EyeLattice::Hexagonal, 1.5),
        (EyeLattice::Hexagonal, 1.7),
    ];
    for (band, angles) in bands {
        let (mut n, mut within, mut same, mut escaping) = (0usize, 0.0, 0usize, 0usize);
        for &(lattice, index) in &lattices {
            for &angle in angles {
                let (polar, azimuth) = (angle.to_radians(), 0.52f32);
                let view = Vec3::new(
                    polar.sin() * azimuth.cos(),
                    polar.sin() * azimuth.sin(),
                    -polar.cos(),
                );
                // Straight down the camera's up vector would be degenerate.
                let view = (view + Vec3::new(1e-3, 0.0, 0.0)).normalize();
                let eye = CompoundEye {
                    facets_per_uv: 7.0,
                    lattice,
                    lens_index: index,
                    prefilter: false,
                    ..default()
                };
                let a = compare_on_normal(quad(), eye, None, None, None, true, view);
                n += a.pixels;
                within += a.within * a.pixels as f64;
                same += a.same_outcome;
                escaping += a.escaping;
            }
        }
        let (within, same) = (within / n as f64, same as f64 / n as f64);
        eprintln!(
            "exact path {band}: {n} px, outcome agrees on {:.3} %, value within 0.02 on {:.3} %, {escaping} escaping",
            100.0 * same,
            100.0 * within
        );
        assert!(
            same >= 0.995 && within >= 0.99,
            "{band}: outcome {same:.4}, within {within:.4}"
        );
    }
}
