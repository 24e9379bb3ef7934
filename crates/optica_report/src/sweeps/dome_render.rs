//! The dome plugin's vertex mode, rendered: a room whose faces are single
//! quads (so every edge on the dome is made by the refinement), drawn by a
//! 180° `DomeCamera` at each pixel tolerance, and measured from the pixels.
//!
//! * Error, from the image: every pixel inside the image circle is
//!   classified by its colour and compared with the face that the CPU
//!   twin's inverse projection of its centre meets. For a wrong pixel, the
//!   true boundary is found by bisection (CPU, f64) between its centre and
//!   the nearest pixel centre that truly shows the drawn face; its distance
//!   from the wrong centre is how far the drawn edge overshoots there.
//!   `pixel_max_px` is the largest such distance (what the tolerance
//!   promises to bound, up to the sampling of pixel centres),
//!   `pixel_wrong_frac` the share of wrong pixels. A background pixel inside
//!   the circle (the rim, clipped at the view plane, drawn as a polyline
//!   that sags inside the circle) counts its distance to the true rim; one
//!   deeper inside is a crack between two of the room's separate meshes
//!   (their shared edge reaches the GPU with different rounding, as it
//!   would through any camera), counted in `crack_pixels`.
//! * Time: the frame, against the same room through Bevy's default
//!   (45°) perspective camera in the same run; `refine_ms`: building the twins on the CPU
//!   (done once for a static camera, each frame for a moving one).

use bevy::camera::visibility::RenderLayers;
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::prelude::*;
use bevy::render::view::Msaa;
use optica_dome::{DomeCamera, DomePlugin, refine_mesh_asset};
use optica_optics::dome::{DomeProjection, SplitRule, cube_face_axis};
use optica_optics::glam::{DVec2, DVec3};

use super::SweepError;
use crate::{Report, Row, SweepContext, time_ms};

/// Outward axis and colour of each face of the box [−1, 1]³ (as in the
/// plugin's render tests).
const FACES: [(Vec3, [u8; 3]); 6] = [
    (Vec3::Y, [255, 0, 0]),
    (Vec3::NEG_Z, [0, 255, 0]),
    (Vec3::Z, [0, 0, 255]),
    (Vec3::X, [255, 255, 0]),
    (Vec3::NEG_X, [255, 0, 255]),
    (Vec3::NEG_Y, [0, 255, 255]),
];

/// Zenith-looking, the back of the theatre towards +Z.
fn camera() -> Transform {
    Transform::IDENTITY.looking_to(Vec3::Y, Vec3::Z)
}

fn face_meshes() -> Vec<(Mesh, Transform, [u8; 3])> {
    FACES
        .iter()
        .map(|&(axis, colour)| {
            let mesh = Plane3d::default().mesh().size(2.0, 2.0).build();
            let rotation = Quat::from_rotation_arc(Vec3::Y, -axis);
            (
                mesh,
                Transform::from_translation(axis).with_rotation(rotation),
                colour,
            )
        })
        .collect()
}

/// The room and a camera: a dome camera of `tolerance_px`, or (None)
/// Bevy's default perspective camera looking at the ceiling.
fn scene(dome: Option<f32>) -> impl FnOnce(&mut App) {
    move |app: &mut App| {
        app.add_plugins(DomePlugin);
        app.add_systems(
            Startup,
            move |mut commands: Commands,
                  mut meshes: ResMut<Assets<Mesh>>,
                  mut materials: ResMut<Assets<StandardMaterial>>| {
                for (mesh, transform, [r, g, b]) in face_meshes() {
                    let material = materials.add(StandardMaterial {
                        base_color: Color::srgb_u8(r, g, b),
                        unlit: true,
                        cull_mode: None,
                        ..default()
                    });
                    commands.spawn((
                        Mesh3d(meshes.add(mesh)),
                        MeshMaterial3d(material),
                        transform,
                    ));
                }
                let look = (
                    Camera {
                        clear_color: ClearColorConfig::Custom(Color::BLACK),
                        ..default()
                    },
                    Tonemapping::None,
                    Msaa::Off,
                    camera(),
                );
                match dome {
                    Some(tolerance_px) => {
                        commands.spawn((
                            DomeCamera {
                                tolerance_px,
                                ..default()
                            },
                            look,
                        ));
                    }
                    None => {
                        commands.spawn((Camera3d::default(), RenderLayers::layer(0), look));
                    }
                }
            },
        );
    }
}

/// The face the ray from the room's centre along `dir` meets.
fn face_of(dir: DVec3) -> usize {
    let axis = cube_face_axis(dir).as_vec3();
    FACES
        .iter()
        .position(|(f, _)| *f == axis)
        .unwrap_or(usize::MAX)
}

/// The face a pixel position truly shows (None outside the image circle).
fn true_face(dome: &DomeProjection, pixel: DVec2) -> Option<usize> {
    let rotation = camera().rotation.as_dquat();
    dome.unproject(pixel).map(|view| face_of(rotation * view))
}

/// (largest overshoot in px, share of wrong pixels, crack pixels) of a
/// room rendered at `tolerance` px.
fn edge_errors(img: &image::RgbaImage, dome: &DomeProjection, tolerance: f64) -> (f64, f64, usize) {
    let size = img.width() as i64;
    let drawn = |x: i64, y: i64| {
        let p = img.get_pixel(x as u32, y as u32).0;
        FACES.iter().position(|(_, c)| *c == [p[0], p[1], p[2]])
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
            // a polyline that sags inside it (geometry is clipped at the
            // view plane), whose overshoot is the distance to the true rim;
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
            // The nearest pixel centre that truly shows the drawn face.
            let mut nearest: Option<DVec2> = None;
            'rings: for ring in 1..=64i64 {
                for dy in -ring..=ring {
                    for dx in -ring..=ring {
                        if dx.abs() != ring && dy.abs() != ring {
                            continue;
                        }
                        let q = centre(x + dx, y + dy);
                        if true_face(dome, q) == Some(got)
                            && nearest.is_none_or(|n| (q - p).length() < (n - p).length())
                        {
                            nearest = Some(q);
                        }
                    }
                }
                if nearest.is_some() {
                    break 'rings;
                }
            }
            let Some(q) = nearest else {
                worst = f64::INFINITY;
                continue;
            };
            // Bisect for the true boundary between p (want) and q (got).
            let (mut a, mut b) = (p, q);
            for _ in 0..40 {
                let m = 0.5 * (a + b);
                if true_face(dome, m) == Some(got) {
                    b = m;
                } else {
                    a = m;
                }
            }
            worst = worst.max((b - p).length());
        }
    }
    (worst, wrong as f64 / inside.max(1) as f64, cracks)
}

/// Appends the rendered rows (series `vertex mode, rendered`).
pub fn rendered_rows(ctx: &SweepContext, report: &mut Report) -> Result<(), SweepError> {
    let size = ctx.pick(256, 2048);
    let tolerances: Vec<f32> = ctx.pick(
        vec![8.0, 1.0, 0.25],
        vec![16.0, 8.0, 4.0, 2.0, 1.0, 0.5, 0.25],
    );
    let (warmup, frames) = ctx.pick((1, 3), (2, 8));
    let headless = ctx.headless(size, size);
    let dome = DomeCamera::default()
        .projection(size)
        .map_err(|e| SweepError::Setup(e.to_string()))?;
    let view_from_world = camera().compute_affine().inverse();
    for (i, &tolerance) in tolerances.iter().enumerate() {
        ctx.progress(
            i + 1,
            tolerances.len(),
            &format!("rendered, tolerance {tolerance} px"),
        );
        let frame = headless.render(scene(Some(tolerance)))?;
        report.adapter.get_or_insert(frame.adapter.clone());
        let (max_px, wrong, cracks) = edge_errors(&frame.to_rgba8(), &dome, f64::from(tolerance));
        let timed = headless.time_frames(warmup, frames, scene(Some(tolerance)))?;
        let plain = headless.time_frames(warmup, frames, scene(None))?;
        let rule = SplitRule::chord_gap(f64::from(tolerance))
            .map_err(|e| SweepError::Setup(e.to_string()))?;
        let faces = face_meshes();
        let (refine_ms, triangles) = time_ms(3, 50.0, || {
            faces
                .iter()
                .filter_map(|(mesh, transform, _)| {
                    refine_mesh_asset(
                        mesh,
                        view_from_world * transform.compute_affine(),
                        &dome,
                        rule,
                    )
                })
                .map(|m| m.indices().map_or(0, |i| i.len() / 3))
                .sum::<usize>()
        });
        report.rows.push(
            Row::new(
                f64::from(tolerance),
                timed.frame_ms.median,
                plain.frame_ms.median,
            )
            .series("vertex mode, rendered")
            .err("pixel_max_px", max_px)
            .err("pixel_wrong_frac", wrong)
            .timing("refine_ms", refine_ms)
            .work("triangles", triangles as f64)
            .work("crack_pixels", cracks as f64)
            .work("size_px", f64::from(size)),
        );
    }
    Ok(())
}
