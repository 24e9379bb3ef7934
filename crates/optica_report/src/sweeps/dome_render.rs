//! The dome plugin rendered: a room whose faces are single quads (so every
//! edge on the dome is made by the refinement), drawn by a 180°
//! `DomeCamera` in the vertex mode at each pixel tolerance and in the
//! cube-map mode at each face size, at the same output size, and measured
//! from the pixels.
//!
//! * Error, from the image: every pixel inside the image circle is
//!   classified by its colour and compared with the face that the CPU
//!   twin's inverse projection of its centre meets (black is the
//!   background; other colours count as the face of the nearest colour in
//!   linear light, which for the cube mode's bilinear blends is the 50 %
//!   line). For a wrong pixel, the distance from its centre to the nearest
//!   point that truly shows the drawn face (searched along 48 rays, then
//!   bisected, CPU, f64) is how far the drawn edge overshoots there.
//!   `pixel_max_px` is the largest such distance (what the tolerance
//!   promises to bound, up to the sampling of pixel centres),
//!   `pixel_wrong_frac` the share of wrong pixels. A background pixel inside
//!   the circle near the rim (the rim drawn as a polyline that sags inside
//!   the circle, as it did when geometry was clipped at the view plane)
//!   counts its distance to the true rim; one
//!   deeper inside is a crack between two of the room's separate meshes
//!   (their shared edge reaches the GPU with different rounding, as it
//!   would through any camera), counted in `crack_pixels`.
//! * Time: the frame (both modes), against the same room through Bevy's
//!   default (45°) perspective camera in the same run; `refine_ms`: building the twins on the CPU
//!   (done once for a static camera, each frame for a moving one).

use bevy::camera::visibility::RenderLayers;
use bevy::core_pipeline::tonemapping::DebandDither;
use bevy::prelude::*;
use bevy::render::view::Msaa;
use optica_dome::{DomeCamera, DomeMode, refine_mesh_asset};
use optica_optics::dome::{DomeProjection, SplitRule, cube_face_axis};
use optica_optics::glam::{DVec2, DVec3};

use super::SweepError;
use crate::fixtures::{
    ROOM_AXES, black_untonemapped, dome_room, room_face, room_face_mesh, zenith,
};
use crate::{Report, Row, SweepContext, time_ms};

/// The colour of each face of the room (`fixtures::ROOM_AXES`). The colours
/// are chosen so that no blend of two of them (in linear light) comes
/// within 0.11 of a blend of two others: a resampled edge pixel names its
/// two faces unambiguously (pure primaries and secondaries would not: the
/// blends of red and cyan and of blue and yellow are the same grey).
const COLOURS: [[u8; 3]; 6] = [
    [4, 23, 218],
    [93, 141, 96],
    [195, 143, 144],
    [12, 248, 172],
    [145, 254, 255],
    [90, 128, 183],
];

/// The room's faces, one quad each, where they lie.
fn face_meshes() -> Vec<(Mesh, Transform)> {
    ROOM_AXES
        .iter()
        .map(|&axis| (room_face_mesh(1), room_face(axis)))
        .collect()
}

/// The room and a camera: `dome`, or (None) Bevy's default perspective
/// camera looking at the ceiling.
pub(super) fn scene(dome: Option<DomeCamera>) -> impl FnOnce(&mut App) {
    let colours = COLOURS.map(|[r, g, b]| Color::srgb_u8(r, g, b));
    dome_room(colours, 1, move |commands| {
        spawn_view(commands, dome, Msaa::Off)
    })
}

/// The view of the dome sweeps' scenes, from the room's centre at the
/// zenith, drawing on black, untonemapped and undithered (Bevy's deband
/// dither moves a sixth of the pixels one grey level, which the exact
/// references do not): `dome`, or (None) Bevy's default perspective
/// camera, the baseline of their frame times.
pub(super) fn spawn_view(commands: &mut Commands, dome: Option<DomeCamera>, msaa: Msaa) {
    let look = (black_untonemapped(msaa), DebandDither::Disabled, zenith());
    match dome {
        Some(dome) => {
            commands.spawn((dome, look));
        }
        None => {
            commands.spawn((Camera3d::default(), RenderLayers::layer(0), look));
        }
    }
}

/// The face the ray from the room's centre along `dir` meets.
fn face_of(dir: DVec3) -> usize {
    let axis = cube_face_axis(dir).as_vec3();
    ROOM_AXES
        .iter()
        .position(|f| *f == axis)
        .unwrap_or(usize::MAX)
}

/// The face a pixel position truly shows (None outside the image circle).
fn true_face(dome: &DomeProjection, pixel: DVec2) -> Option<usize> {
    let rotation = zenith().rotation.as_dquat();
    dome.unproject(pixel).map(|view| face_of(rotation * view))
}

/// Directions searched for the nearest true boundary around a wrong pixel
/// (7.5° apart: the distance found is within 1 % of the perpendicular one
/// for a boundary that is straight at pixel scale).
const SEARCH_DIRECTIONS: usize = 48;

/// The distance from `p` to the nearest point that truly shows `face` or
/// lies outside the image circle (beyond the field of view anything may
/// show: a face drawn from there reaches in by that distance), searched
/// along `SEARCH_DIRECTIONS` rays up to `reach` px (coarse steps, then
/// bisection on the first crossing of each ray).
fn distance_to_face(dome: &DomeProjection, p: DVec2, face: usize, reach: f64) -> f64 {
    let shows = |q: DVec2| match true_face(dome, q) {
        Some(f) => f == face,
        None => true,
    };
    let steps = 64;
    let mut best = f64::INFINITY;
    for k in 0..SEARCH_DIRECTIONS {
        let angle = std::f64::consts::TAU * k as f64 / SEARCH_DIRECTIONS as f64;
        let dir = DVec2::new(angle.cos(), angle.sin());
        let mut before = 0.0;
        for i in 1..=steps {
            // No farther than the best distance found so far: a crossing
            // beyond it cannot improve on it.
            let t = (reach * f64::from(i) / f64::from(steps)).min(best);
            if shows(p + t * dir) {
                let (mut a, mut b) = (before, t);
                for _ in 0..40 {
                    let m = 0.5 * (a + b);
                    if shows(p + m * dir) {
                        b = m;
                    } else {
                        a = m;
                    }
                }
                best = best.min(b);
                break;
            }
            if t >= best {
                break;
            }
            before = t;
        }
    }
    best
}

/// (largest overshoot in px, share of wrong pixels, crack pixels) of a
/// room rendered at `tolerance` px.
fn edge_errors(img: &image::RgbaImage, dome: &DomeProjection, tolerance: f64) -> (f64, f64, usize) {
    let size = img.width() as i64;
    // A pixel's face: black is the background (None), a face's own colour
    // that face (the vertex mode draws nothing else). Any other colour is a
    // blend in linear light of the faces around an edge or corner (the cube
    // mode resamples bilinearly): it is read as the blend of two of the
    // faces truly present within 4 px that fits best, and as the face that
    // weighs more in it — the 50 % line is the drawn edge; a blend no pair
    // fits (a corner's three faces) as the nearby face nearest in colour.
    let linear = |v: u8| {
        let c = f64::from(v) / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    let colours: Vec<DVec3> = COLOURS
        .iter()
        .map(|c| DVec3::new(linear(c[0]), linear(c[1]), linear(c[2])))
        .collect();
    let fit = |p: DVec3, candidates: &[usize]| {
        let mut best = (f64::INFINITY, usize::MAX);
        for (n, &i) in candidates.iter().enumerate() {
            for &j in &candidates[n..] {
                let d = colours[i] - colours[j];
                let w = if d.length_squared() > 0.0 {
                    ((p - colours[j]).dot(d) / d.length_squared()).clamp(0.0, 1.0)
                } else {
                    1.0
                };
                let residual = (p - (colours[j] + w * d)).length_squared();
                if residual < best.0 {
                    best = (residual, if w >= 0.5 { i } else { j });
                }
            }
        }
        best
    };
    let all: Vec<usize> = (0..COLOURS.len()).collect();
    let drawn = |x: i64, y: i64| {
        let raw = img.get_pixel(x as u32, y as u32).0;
        if raw[..3].iter().all(|&v| v < 8) {
            return None;
        }
        if let Some(k) = COLOURS.iter().position(|c| *c == [raw[0], raw[1], raw[2]]) {
            return Some(k);
        }
        let p = DVec3::new(linear(raw[0]), linear(raw[1]), linear(raw[2]));
        let c = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
        const STEPS: [f64; 5] = [-4.0, -2.0, 0.0, 2.0, 4.0];
        let mut near: Vec<usize> = STEPS
            .iter()
            .flat_map(|&dx| STEPS.map(|dy| DVec2::new(dx, dy)))
            .filter_map(|o| true_face(dome, c + o))
            .collect();
        near.sort_unstable();
        near.dedup();
        if near.is_empty() {
            return Some(fit(p, &all).1);
        }
        let (residual, face) = fit(p, &near);
        if residual < 1e-3 {
            return Some(face);
        }
        // A corner's blend of three: the nearby face of the nearest colour.
        near.iter().copied().min_by(|&a, &b| {
            (colours[a] - p)
                .length_squared()
                .total_cmp(&(colours[b] - p).length_squared())
        })
    };
    let centre = |x: i64, y: i64| DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
    let rim = dome.rim_radius_px() - 1.0;
    let (mut inside, mut wrong, mut worst, mut cracks) = (0usize, 0usize, 0f64, 0usize);
    for y in 0..size {
        for x in 0..size {
            let p = centre(x, y);
            if (p - dome.centre_px()).length() > rim {
                continue;
            }
            inside += 1;
            let Some(want) = true_face(dome, p) else {
                continue;
            };
            let got = drawn(x, y);
            if got == Some(want) {
                continue;
            }
            wrong += 1;
            // Background inside the circle: near the rim, the rim drawn as
            // a polyline that sags inside it (were geometry clipped at the
            // rim), whose overshoot is the distance to the true rim;
            // deeper inside, a crack between two separate meshes whose
            // shared edge the GPU sees with different rounding.
            let Some(got) = got else {
                let depth = dome.rim_radius_px() - (p - dome.centre_px()).length();
                if depth > 2.0 * tolerance + 2.0 {
                    cracks += 1;
                } else {
                    worst = worst.max(depth);
                }
                continue;
            };
            // How far the drawn face reaches past its true boundary here.
            let d = distance_to_face(dome, p, got, 64.0);
            worst = worst.max(d);
        }
    }
    (worst, wrong as f64 / inside.max(1) as f64, cracks)
}

/// What one rendered configuration measured.
struct Measured {
    max_px: f64,
    wrong: f64,
    cracks: usize,
    /// The dome's frame against the perspective camera's.
    paired: optica_harness::PairedTimings,
}

/// Renders the room through `camera` at `size`, measures its edges and
/// times it against Bevy's perspective camera in alternating blocks.
fn measure(
    ctx: &SweepContext,
    report: &mut Report,
    size: u32,
    camera: DomeCamera,
    tolerance: f64,
) -> Result<Measured, SweepError> {
    let warmup = ctx.pick(1, 2);
    let headless = ctx.headless(size, size);
    let dome = camera
        .projection(size)
        .map_err(|e| SweepError::Setup(e.to_string()))?;
    let frame = headless.render(scene(Some(camera)))?;
    report.adapter.get_or_insert(frame.adapter.clone());
    let (max_px, wrong, cracks) = edge_errors(&frame.to_rgba8(), &dome, tolerance);
    let (blocks, per_block) = ctx.blocks();
    let paired =
        headless.time_paired(warmup, blocks, per_block, scene(Some(camera)), scene(None))?;
    Ok(Measured {
        max_px,
        wrong,
        cracks,
        paired,
    })
}

/// Appends the rendered rows: series `vertex mode, rendered` (knob: pixel
/// tolerance) and `cube mode, rendered` (knob: face size in px) at the
/// same output size, so their times compare at equal error.
pub fn rendered_rows(ctx: &SweepContext, report: &mut Report) -> Result<(), SweepError> {
    let size = ctx.pick(256, 2048);
    let tolerances: Vec<f32> = ctx.pick(
        vec![8.0, 1.0, 0.25],
        vec![16.0, 8.0, 4.0, 2.0, 1.0, 0.5, 0.25],
    );
    let faces: Vec<u32> = ctx.pick(
        vec![48, 96, 192],
        vec![192, 384, 768, 1024, 1536, 2048, 3072],
    );
    let dome = DomeCamera::default()
        .projection(size)
        .map_err(|e| SweepError::Setup(e.to_string()))?;
    let view_from_world = zenith().compute_affine().inverse();
    let steps = tolerances.len() + faces.len();
    for (i, &tolerance) in tolerances.iter().enumerate() {
        ctx.progress(
            i + 1,
            steps,
            &format!("vertex mode, tolerance {tolerance} px"),
        );
        let camera = DomeCamera {
            tolerance_px: tolerance,
            ..default()
        };
        let m = measure(ctx, report, size, camera, f64::from(tolerance))?;
        let rule = SplitRule::chord_gap(f64::from(tolerance))
            .map_err(|e| SweepError::Setup(e.to_string()))?;
        let meshes = face_meshes();
        let (refine_ms, triangles) = time_ms(3, 50.0, || {
            meshes
                .iter()
                .filter_map(|(mesh, transform)| {
                    refine_mesh_asset(
                        mesh,
                        view_from_world * transform.compute_affine(),
                        &dome.into(),
                        rule,
                    )
                })
                .map(|m| m.indices().map_or(0, |i| i.len() / 3))
                .sum::<usize>()
        });
        report.rows.push(
            Row::paired(f64::from(tolerance), &m.paired)
                .series("vertex mode, rendered")
                .err("pixel_max_px", m.max_px)
                .err("pixel_wrong_frac", m.wrong)
                .timing("refine_ms", refine_ms)
                .work("triangles", triangles as f64)
                .work("crack_pixels", m.cracks as f64)
                .work("size_px", f64::from(size)),
        );
    }
    // The goal's second size: the vertex mode at 4K and 0.5 px (full run).
    if !ctx.quick {
        let camera = DomeCamera::default();
        let m = measure(ctx, report, 4096, camera, f64::from(camera.tolerance_px))?;
        report.rows.push(
            Row::paired(f64::from(camera.tolerance_px), &m.paired)
                .series("vertex mode, rendered, 4K")
                .err("pixel_max_px", m.max_px)
                .err("pixel_wrong_frac", m.wrong)
                .work("crack_pixels", m.cracks as f64)
                .work("size_px", 4096.0),
        );
    }
    for (i, &face_px) in faces.iter().enumerate() {
        ctx.progress(
            tolerances.len() + i + 1,
            steps,
            &format!("cube mode, faces of {face_px} px"),
        );
        let camera = DomeCamera {
            mode: DomeMode::CubeMap { face_px },
            ..default()
        };
        // Cracks do not arise in the cube mode; every wrong pixel counts.
        let m = measure(ctx, report, size, camera, f64::INFINITY)?;
        report.rows.push(
            Row::paired(f64::from(face_px), &m.paired)
                .series("cube mode, rendered")
                .err("pixel_max_px", m.max_px)
                .err("pixel_wrong_frac", m.wrong)
                .work("faces", 4.0)
                .work("face_pixels", 4.0 * f64::from(face_px).powi(2))
                .work("size_px", f64::from(size)),
        );
    }
    Ok(())
}
