//! The two dome modes on textured content, against an exact per-pixel
//! reference: what edge positions (`dome_render.rs`) do not show — the cube
//! mode's resampling blurs textures and one-pixel stars; the vertex mode
//! takes each fragment's attributes at its own ray (series `textured
//! room, vertex mode, interpolated attributes`: the rasteriser's
//! interpolation across each refined triangle's image instead, at 0.5 px).
//!
//! * Scenes, both through a zenith 180° `DomeCamera` (equidistant, no
//!   tonemapping, unlit materials, so a pixel's colour is the texture's; no
//!   MSAA, and the vertex mode again with 4× MSAA — series `<scene>, vertex
//!   mode, 4× MSAA` — which smooths triangle edges, the stars, but not
//!   texture content):
//!   - *textured room*: the box [−1, 1]³ around the camera, each face one
//!     quad carrying a 16 × 16 checkerboard (sRGB 48 and 208, sampled
//!     nearest, as a texture of 128² texels);
//!   - *star field*: 2,000 white square stars on black, each facing the
//!     camera and one domemaster pixel wide (1/f rad, f = size/π px/rad),
//!     seeded over the sky up to 88° from the zenith.
//! * Reference: the CPU twin casting rays through every pixel
//!   ([`DomeProjection::unproject`], f64) into the same scene: the room's
//!   face and checker cell by a ray–box hit, a star by a ray–square hit;
//!   averaged in linear light over 4 × 4 sub-pixel rays (room) or 8 × 8
//!   (stars) — the anti-aliased image the frame should approximate. A
//!   second, point-sampled reference (one ray through each pixel centre,
//!   what a rasteriser samples) separates the mapping's exactness from
//!   aliasing: `_point` errors.
//! * Errors, over the pixels whose centre lies 1 px or more inside the
//!   image circle: `flip_mean` (ꟻLIP at 67 px/°), `psnr_db`, and the same
//!   against the point-sampled reference.
//! * Time: the frame in each mode and Bevy's default perspective camera
//!   on the same scene, timed in alternating blocks (`baseline_time_ms`;
//!   the ratio with its 95 % interval is each mode's cost in views).
//! * Work: `fragments`, the pixels the scene's triangles cover in the
//!   frame (vertex mode: the twins' projected areas, CPU; these scenes have
//!   no overdraw) or the face images' pixels (cube mode: `face_pixels`, all
//!   of which the room covers) plus the full-screen resampling pass
//!   (`resample_fragments`, one per output pixel); `triangles` drawn.

use std::f64::consts::PI;

use bevy::asset::RenderAssetUsages;
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use bevy::render::view::Msaa;
use optica_dome::twins::CubeLayout;
use optica_dome::{DomeCamera, DomeMode, DomePlugin, refine_mesh_asset};
use optica_harness::metrics::flip_map;
use optica_optics::dome::{DomeProjection, SplitRule};
use optica_optics::glam::{DQuat, DVec2, DVec3};
use rayon::prelude::*;

use super::SweepError;
use crate::fixtures::{unlit, zenith};
use crate::{Report, Row, SweepContext};

/// Checker cells along a face's side, and the texture's texels.
const CELLS: u32 = 16;
const TEXELS: u32 = 128;
/// The checker's two grey levels (sRGB).
const DARK: u8 = 48;
const LIGHT: u8 = 208;
/// Stars in the field, their distance and how far from the zenith they go.
const STARS: usize = 2000;
const STAR_DISTANCE: f64 = 10.0;
const STAR_MAX_POLAR_DEG: f64 = 88.0;

/// The room's faces: outward axis and the two axes its texture runs along.
fn room_faces() -> [(DVec3, DVec3, DVec3); 6] {
    [
        (DVec3::Y, DVec3::X, DVec3::Z),
        (DVec3::NEG_Y, DVec3::X, DVec3::Z),
        (DVec3::X, DVec3::Z, DVec3::Y),
        (DVec3::NEG_X, DVec3::Z, DVec3::Y),
        (DVec3::Z, DVec3::X, DVec3::Y),
        (DVec3::NEG_Z, DVec3::X, DVec3::Y),
    ]
}

/// Texture coordinates of a point `p` on the face `(axis, s, t)`.
fn face_uv(p: DVec3, s: DVec3, t: DVec3) -> DVec2 {
    DVec2::new(0.5 * (p.dot(s) + 1.0), 0.5 * (1.0 - p.dot(t)))
}

/// One quad per face, in world space, with texture coordinates.
fn room_mesh() -> Mesh {
    let (mut positions, mut normals, mut uvs, mut indices) = (vec![], vec![], vec![], vec![]);
    for (axis, s, t) in room_faces() {
        let base = positions.len() as u32;
        for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            let p = axis + a * s + b * t;
            positions.push(p.as_vec3().to_array());
            normals.push((-axis).as_vec3().to_array());
            uvs.push(face_uv(p, s, t).as_vec2().to_array());
        }
        indices.extend([0, 1, 2, 0, 2, 3].map(|i| base + i));
    }
    mesh_of(positions, normals, indices).with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, uvs)
}

/// A triangle list of these vertices and indices.
fn mesh_of(positions: Vec<[f32; 3]>, normals: Vec<[f32; 3]>, indices: Vec<u32>) -> Mesh {
    Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
    .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, normals)
    .with_inserted_indices(Indices::U32(indices))
}

/// sRGB byte to linear light.
fn linear(v: u8) -> f64 {
    let c = f64::from(v) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear light to the nearest sRGB byte.
fn encode(l: f64) -> u8 {
    let l = l.clamp(0.0, 1.0);
    let c = if l <= 0.003_130_8 {
        12.92 * l
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    };
    (c * 255.0).round() as u8
}

/// The checker's linear value where the world ray `dir` from the room's
/// centre meets the room (nearest texel, as the GPU samples it).
fn room_radiance(dir: DVec3) -> f64 {
    let m = dir.abs().max_element();
    let p = dir / m;
    let (_, s, t) = room_faces()
        .into_iter()
        .max_by(|a, b| a.0.dot(p).total_cmp(&b.0.dot(p)))
        .expect("six faces");
    let uv = face_uv(p, s, t);
    let texel = |c: f64| ((c * f64::from(TEXELS)).floor() as i64).clamp(0, i64::from(TEXELS) - 1);
    let cell = |c: f64| texel(c) * i64::from(CELLS) / i64::from(TEXELS);
    if (cell(uv.x) + cell(uv.y)) % 2 == 0 {
        linear(LIGHT)
    } else {
        linear(DARK)
    }
}

/// A star: its centre direction (world, unit) and two unit axes across it.
#[derive(Clone, Copy)]
struct Star {
    dir: DVec3,
    e1: DVec3,
    e2: DVec3,
}

/// The seeded star field (SplitMix64), uniform in solid angle up to
/// `STAR_MAX_POLAR_DEG` from the zenith (world +Y).
fn stars() -> Vec<Star> {
    let mut state = 0x5EED_57A2_u64;
    let mut next = move || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    let lowest = STAR_MAX_POLAR_DEG.to_radians().cos();
    (0..STARS)
        .map(|_| {
            let y = lowest + (1.0 - lowest) * next();
            let phi = 2.0 * PI * next();
            let r = (1.0 - y * y).max(0.0).sqrt();
            let dir = DVec3::new(r * phi.cos(), y, r * phi.sin());
            let e1 = dir.any_orthonormal_vector();
            Star {
                dir,
                e1,
                e2: dir.cross(e1),
            }
        })
        .collect()
}

/// Half the side of a star in metres: one pixel at the centre of a
/// `size`-px 180° equidistant domemaster subtends π/size rad.
fn star_half_side(size: u32) -> f64 {
    0.5 * STAR_DISTANCE * PI / f64::from(size)
}

/// The star field as one mesh of quads facing the camera.
fn star_mesh(size: u32) -> Mesh {
    let h = star_half_side(size);
    let (mut positions, mut normals, mut indices) = (vec![], vec![], vec![]);
    for star in stars() {
        let base = positions.len() as u32;
        let c = star.dir * STAR_DISTANCE;
        for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            positions.push((c + h * (a * star.e1 + b * star.e2)).as_vec3().to_array());
            normals.push((-star.dir).as_vec3().to_array());
        }
        indices.extend([0, 1, 2, 0, 2, 3].map(|i| base + i));
    }
    mesh_of(positions, normals, indices)
}

/// Which textured scene.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Content {
    Room,
    Stars,
}

impl Content {
    fn name(self) -> &'static str {
        match self {
            Content::Room => "textured room",
            Content::Stars => "star field",
        }
    }

    fn mesh(self, size: u32) -> Mesh {
        match self {
            Content::Room => room_mesh(),
            Content::Stars => star_mesh(size),
        }
    }
}

/// The scene `content` (made for a `size`-px frame) and a camera: `dome`,
/// or (None) Bevy's default perspective camera looking at the zenith.
fn scene(
    content: Content,
    size: u32,
    dome: Option<DomeCamera>,
    msaa: Msaa,
) -> impl FnOnce(&mut App) {
    move |app: &mut App| {
        app.add_plugins(DomePlugin);
        app.add_systems(
            Startup,
            move |mut commands: Commands,
                  mut meshes: ResMut<Assets<Mesh>>,
                  mut images: ResMut<Assets<Image>>,
                  mut materials: ResMut<Assets<StandardMaterial>>| {
                let texture = match content {
                    Content::Room => Some(images.add(optica_harness::textures::checker(
                        TEXELS, CELLS, DARK, LIGHT,
                    ))),
                    Content::Stars => None,
                };
                let material = materials.add(StandardMaterial {
                    base_color_texture: texture,
                    ..unlit(Color::WHITE)
                });
                commands.spawn((
                    Mesh3d(meshes.add(content.mesh(size))),
                    MeshMaterial3d(material),
                    Transform::IDENTITY,
                ));
                super::dome_render::spawn_view(&mut commands, dome, msaa);
            },
        );
    }
}

/// A reference frame in linear light, row-major, `size`² values (grey).
struct Reference {
    size: u32,
    linear: Vec<f64>,
}

impl Reference {
    fn to_rgba8(&self) -> image::RgbaImage {
        image::RgbaImage::from_fn(self.size, self.size, |x, y| {
            let v = encode(self.linear[(y * self.size + x) as usize]);
            image::Rgba([v, v, v, 255])
        })
    }
}

/// The camera's rotation, world from view.
fn camera_rotation() -> DQuat {
    zenith().rotation.as_dquat()
}

/// World direction seen at `pixel` (None beyond the image circle).
fn world_ray(dome: &DomeProjection, pixel: DVec2) -> Option<DVec3> {
    dome.unproject(pixel).map(|view| camera_rotation() * view)
}

/// The sub-pixel offsets of an `n` × `n` grid (n = 1: the pixel centre).
fn offsets(n: u32) -> Vec<DVec2> {
    let step = 1.0 / f64::from(n);
    (0..n)
        .flat_map(|j| (0..n).map(move |i| DVec2::new(i as f64 + 0.5, j as f64 + 0.5) * step))
        .collect()
}

/// The room by rays through `n` × `n` points of every pixel.
fn reference_room(dome: &DomeProjection, size: u32, n: u32) -> Reference {
    let offsets = offsets(n);
    let linear = (0..size * size)
        .into_par_iter()
        .map(|k| {
            let corner = DVec2::new(f64::from(k % size), f64::from(k / size));
            offsets
                .iter()
                .map(|&o| world_ray(dome, corner + o).map_or(0.0, room_radiance))
                .sum::<f64>()
                / offsets.len() as f64
        })
        .collect();
    Reference { size, linear }
}

/// The star field by rays through `n` × `n` points of every pixel near a
/// star (each star's projected corners, widened by 2 px, bound the pixels
/// it can reach).
fn reference_stars(dome: &DomeProjection, size: u32, n: u32) -> Reference {
    let offsets = offsets(n);
    let h = star_half_side(size);
    let view_from_world = camera_rotation().inverse();
    let mut linear = vec![0.0; (size * size) as usize];
    for star in stars() {
        let c = star.dir * STAR_DISTANCE;
        let corners: Vec<DVec2> = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .iter()
            .filter_map(|&(a, b)| {
                dome.pixel_of_direction(view_from_world * (c + h * (a * star.e1 + b * star.e2)))
            })
            .collect();
        if corners.len() < 4 {
            continue;
        }
        let lo = corners.iter().fold(DVec2::INFINITY, |m, &p| m.min(p)) - 2.0;
        let hi = corners.iter().fold(DVec2::NEG_INFINITY, |m, &p| m.max(p)) + 2.0;
        let (x0, y0) = (lo.x.floor().max(0.0) as u32, lo.y.floor().max(0.0) as u32);
        let x1 = (hi.x.ceil().max(0.0) as u32).min(size);
        let y1 = (hi.y.ceil().max(0.0) as u32).min(size);
        for y in y0..y1 {
            for x in x0..x1 {
                let corner = DVec2::new(f64::from(x), f64::from(y));
                let hits = offsets
                    .iter()
                    .filter(|&&o| {
                        world_ray(dome, corner + o).is_some_and(|w| {
                            let facing = w.dot(star.dir);
                            if facing <= 0.0 {
                                return false;
                            }
                            let q = w * (STAR_DISTANCE / facing) - c;
                            q.dot(star.e1).abs() <= h && q.dot(star.e2).abs() <= h
                        })
                    })
                    .count();
                let v = &mut linear[(y * size + x) as usize];
                *v = (*v + hits as f64 / offsets.len() as f64).min(1.0);
            }
        }
    }
    Reference { size, linear }
}

/// The pixels compared: centres at least 1 px inside the image circle.
fn compared(dome: &DomeProjection, size: u32) -> Vec<bool> {
    let rim = dome.rim_radius_px() - 1.0;
    (0..size * size)
        .map(|k| {
            let p = DVec2::new(f64::from(k % size) + 0.5, f64::from(k / size) + 0.5);
            (p - dome.centre_px()).length() <= rim
        })
        .collect()
}

/// (mean ꟻLIP, PSNR in dB) of `frame` against `reference` over `mask`.
fn errors(reference: &image::RgbaImage, frame: &image::RgbaImage, mask: &[bool]) -> (f64, f64) {
    let flip = flip_map(reference, frame).expect("same size");
    let (mut flip_sum, mut sq, mut n) = (0.0, 0.0, 0usize);
    for (k, (a, b)) in reference.pixels().zip(frame.pixels()).enumerate() {
        if !mask[k] {
            continue;
        }
        flip_sum += f64::from(flip[k]);
        for c in 0..3 {
            sq += (f64::from(a[c]) - f64::from(b[c])).powi(2);
        }
        n += 1;
    }
    let n = n.max(1) as f64;
    let mse = sq / (3.0 * n);
    // A frame equal to the reference has no finite PSNR; cap it at the
    // PSNR of one grey level off everywhere (48.1 dB) to keep rows finite.
    let psnr = 10.0 * (255.0f64.powi(2) / mse.max(1.0)).log10();
    (flip_sum / n, psnr)
}

/// Pixels covered by the refined twins of `content` (CPU, projected
/// areas), and their triangles.
fn twin_coverage(
    content: Content,
    size: u32,
    dome: &DomeProjection,
    tolerance: f64,
) -> (f64, usize) {
    let rule = SplitRule::chord_gap(tolerance).expect("positive tolerance");
    let view_from_world = zenith().compute_affine().inverse();
    let Some(twin) = refine_mesh_asset(&content.mesh(size), view_from_world, &(*dome).into(), rule)
    else {
        return (0.0, 0);
    };
    let Some(bevy::mesh::VertexAttributeValues::Float32x3(positions)) =
        twin.attribute(Mesh::ATTRIBUTE_POSITION)
    else {
        return (0.0, 0);
    };
    let pixel = |i: usize| {
        let p = view_from_world.transform_point3(Vec3::from_array(positions[i]));
        dome.pixel_of_direction(p.as_dvec3())
    };
    let indices: Vec<usize> = twin.indices().map_or(vec![], |i| i.iter().collect());
    let mut area = 0.0;
    for t in indices.chunks_exact(3) {
        if let (Some(a), Some(b), Some(c)) = (pixel(t[0]), pixel(t[1]), pixel(t[2])) {
            area += 0.5 * (b - a).perp_dot(c - a).abs();
        }
    }
    (area, indices.len() / 3)
}

/// Face pixels the stars cover in the cube mode: each star's solid angle
/// times the pixel density of the face it falls in, `(f/cos³γ)` per
/// steradian with f = (N − 2)/2 px per unit tangent (faces of N px carry
/// a guard texel each side) and γ the angle from that face's axis.
fn star_face_pixels(camera: &DomeCamera, face_px: u32, size: u32) -> f64 {
    let layout = CubeLayout::of(camera);
    let cube_from_view = layout.view_from_cube.transpose().as_dmat3();
    let view_from_world = camera_rotation().inverse();
    let f = 0.5 * (f64::from(face_px) - 2.0);
    let solid_angle = (2.0 * star_half_side(size) / STAR_DISTANCE).powi(2);
    stars()
        .iter()
        .map(|star| {
            let d = cube_from_view * (view_from_world * star.dir);
            let cos = d.abs().max_element();
            solid_angle * f * f / cos.powi(3)
        })
        .sum()
}

/// One scene's references.
struct Bench {
    content: Content,
    size: u32,
    dome: DomeProjection,
    mask: Vec<bool>,
    supersampled: image::RgbaImage,
    point: image::RgbaImage,
}

impl Bench {
    fn new(content: Content, size: u32) -> Result<Self, SweepError> {
        let dome = DomeCamera::default()
            .projection(size)
            .map_err(|e| SweepError::Setup(e.to_string()))?;
        let (supersampled, point) = match content {
            Content::Room => (
                reference_room(&dome, size, 4),
                reference_room(&dome, size, 1),
            ),
            Content::Stars => (
                reference_stars(&dome, size, 8),
                reference_stars(&dome, size, 1),
            ),
        };
        Ok(Self {
            content,
            size,
            mask: compared(&dome, size),
            dome,
            supersampled: supersampled.to_rgba8(),
            point: point.to_rgba8(),
        })
    }

    /// Renders and times the scene through `camera`; a row of series
    /// `<scene>, <mode>` at `knob` with its errors.
    fn row(
        &self,
        ctx: &SweepContext,
        report: &mut Report,
        camera: DomeCamera,
        msaa: Msaa,
        knob: f64,
    ) -> Result<Row, SweepError> {
        let headless = ctx.headless(self.size, self.size);
        let frame = headless.render(scene(self.content, self.size, Some(camera), msaa))?;
        report.adapter.get_or_insert(frame.adapter.clone());
        let image = frame.to_rgba8();
        let (flip, psnr) = errors(&self.supersampled, &image, &self.mask);
        let (flip_point, psnr_point) = errors(&self.point, &image, &self.mask);
        // Against the perspective view of the same scene, in alternating blocks.
        let warmup = ctx.pick(1, 2);
        let (blocks, per_block) = ctx.blocks();
        let paired = headless.time_paired(
            warmup,
            blocks,
            per_block,
            scene(self.content, self.size, Some(camera), msaa),
            scene(self.content, self.size, None, Msaa::Off),
        )?;
        let mode = match (camera.mode, msaa) {
            (DomeMode::Vertex, _) if !camera.exact_attributes => {
                "vertex mode, interpolated attributes"
            }
            (DomeMode::Vertex, Msaa::Off) => "vertex mode",
            (DomeMode::Vertex, _) => "vertex mode, 4× MSAA",
            (DomeMode::CubeMap { .. }, _) => "cube mode",
        };
        Ok(Row::paired(knob, &paired)
            .series(&format!("{}, {mode}", self.content.name()))
            .err("flip_mean", flip)
            .err("psnr_db", psnr)
            .err("flip_point", flip_point)
            .err("psnr_point_db", psnr_point)
            .work("size_px", f64::from(self.size)))
    }
}

/// The textured room through a zenith dome camera `camera` at `size` px
/// (one sample per pixel; the default lens and field of view, as the
/// sweep's references take them: only the tolerance and
/// `exact_attributes` may differ), its point-sampled reference (the CPU twin's ray
/// through each pixel centre) and the pixels compared (1 px or more inside
/// the image circle). For the render tests' check that the vertex mode's
/// texture is exact inside triangles.
pub fn room_against_point_reference(
    headless: &optica_harness::Headless,
    size: u32,
    camera: DomeCamera,
) -> Result<(image::RgbaImage, image::RgbaImage, Vec<bool>), SweepError> {
    let bench = Bench::new(Content::Room, size)?;
    let frame = headless.render(scene(Content::Room, size, Some(camera), Msaa::Off))?;
    Ok((frame.to_rgba8(), bench.point, bench.mask))
}

/// Appends the textured comparison: for each scene, series `<scene>,
/// vertex mode` (knob: pixel tolerance) and `<scene>, cube mode` (knob:
/// face size in px), all at one output size.
pub fn textured_rows(ctx: &SweepContext, report: &mut Report) -> Result<(), SweepError> {
    let size = ctx.pick(256, 1024);
    let tolerances: Vec<f32> = ctx.pick(vec![0.5], vec![2.0, 0.5, 0.1]);
    let faces: Vec<u32> = ctx.pick(vec![128, 512], vec![256, 512, 768, 1024, 1536, 2048]);
    let steps = 2 * (2 * tolerances.len() + faces.len()) + 1;
    let mut step = 0;
    let mut floor = f64::NAN;
    for content in [Content::Room, Content::Stars] {
        let bench = Bench::new(content, size)?;
        if content == Content::Room {
            // The best one sample per pixel can do: the point-sampled
            // reference itself against the supersampled one.
            floor = errors(&bench.supersampled, &bench.point, &bench.mask).0;
        }
        for &tolerance in &tolerances {
            // The twin's coverage does not depend on the sample count.
            let (fragments, triangles) =
                twin_coverage(content, size, &bench.dome, f64::from(tolerance));
            for (msaa, samples) in [(Msaa::Off, 1.0), (Msaa::Sample4, 4.0)] {
                step += 1;
                ctx.progress(
                    step,
                    steps,
                    &format!(
                        "{}, vertex mode, {tolerance} px, {samples} samples",
                        content.name()
                    ),
                );
                let camera = DomeCamera {
                    tolerance_px: tolerance,
                    ..default()
                };
                let row = bench.row(ctx, report, camera, msaa, f64::from(tolerance))?;
                report.rows.push(
                    row.work("fragments", fragments)
                        .work("samples_per_pixel", samples)
                        .work("triangles", triangles as f64),
                );
            }
            // What exact attributes cost and gain: the room at the default
            // tolerance with the rasteriser's interpolated ones.
            if content == Content::Room && tolerance == 0.5 {
                step += 1;
                ctx.progress(
                    step,
                    steps,
                    "textured room, vertex mode, interpolated attributes",
                );
                let camera = DomeCamera {
                    tolerance_px: tolerance,
                    exact_attributes: false,
                    ..default()
                };
                let row = bench.row(ctx, report, camera, Msaa::Off, f64::from(tolerance))?;
                report.rows.push(
                    row.work("fragments", fragments)
                        .work("samples_per_pixel", 1.0)
                        .work("triangles", triangles as f64),
                );
            }
        }
        for &face_px in &faces {
            step += 1;
            ctx.progress(
                step,
                steps,
                &format!("{}, cube mode, faces of {face_px} px", content.name()),
            );
            let camera = DomeCamera {
                mode: DomeMode::CubeMap { face_px },
                ..default()
            };
            let row = bench.row(ctx, report, camera, Msaa::Off, f64::from(face_px))?;
            let face_pixels = 4.0 * f64::from(face_px).powi(2);
            let resample = f64::from(size).powi(2);
            let covered = match content {
                Content::Room => face_pixels,
                Content::Stars => star_face_pixels(&camera, face_px, size),
            };
            report.rows.push(
                row.work("fragments", covered + resample)
                    .work("face_pixels", face_pixels)
                    .work("resample_fragments", resample)
                    .work("faces", 4.0),
            );
        }
    }
    texture_goal(report, size, floor);
    Ok(())
}

/// The vertex mode's goal on the textured room: ꟻLIP at most 0.025 against
/// the supersampled reference at 0.5 px, at most 1.4× a perspective view
/// at the ratio's upper bound; judged at the full run's 1024 px (the quick
/// run's 256 px puts more of the frame on checker edges, which one sample
/// per pixel cannot anti-alias). Recorded as a stability case that says
/// met or not met, as `Report::ratio_goal` does, with `floor`: the ꟻLIP of
/// the point-sampled reference itself, the least a frame of one sample per
/// pixel can score.
fn texture_goal(report: &mut Report, size: u32, floor: f64) {
    const FLIP: f64 = 0.025;
    const RATIO: f64 = 1.4;
    let row = report
        .rows
        .iter()
        .find(|r| r.series == "textured room, vertex mode" && r.knob == 0.5);
    let (measured, detail) = match row {
        Some(r) => {
            let flip = r.error["flip_mean"];
            let met = flip <= FLIP && r.ratio_high() <= RATIO;
            (
                flip.is_finite() && r.ratio_high().is_finite(),
                format!(
                    "goal at 1024 px: ꟻLIP ≤ {FLIP} at ≤ {RATIO}× (upper bound), {}: at {size} px ꟻLIP {flip:.4} (against the point-sampled reference {:.4}; that reference itself scores {floor:.4}), {:.2} [{:.2}, {:.2}]×",
                    if met && size >= 1024 {
                        "met"
                    } else {
                        "not met"
                    },
                    r.error["flip_point"],
                    r.ratio(),
                    r.ratio.map_or(f64::NAN, |i| i.low),
                    r.ratio_high()
                ),
            )
        }
        None => (
            false,
            "no textured-room vertex-mode row at 0.5 px".to_string(),
        ),
    };
    report.case(
        "textured room, vertex mode at 0.5 px: exact texture at ≤ 1.4× a perspective view",
        measured,
        detail,
    );
}
