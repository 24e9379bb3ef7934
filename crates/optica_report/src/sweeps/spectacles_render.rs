//! The spectacles plugin itself on the adapter: its rows in the
//! `spectacles` report (series named in [`rendered_rows`]).
//!
//! * Scene: the paper's Fig. 8 room as checkerboards straight ahead of the
//!   eye — a book at 0.3 m, a card at 1 m, an eye chart at 5 m — for the
//!   error rows unlit (a pixel is its texture's colour, so the error is the
//!   blur's alone), for the timed rows lit (Bevy's PBR, a directional light
//!   with shadows, a floor). 256² px (one timed row at 512²), 0.8 rad
//!   vertical field of view.
//! * Eye: Fig. 8(b)'s short-sighted presbyope, near point 0.5 m, far point
//!   1.3 m, pupil 12 mm: the book is blurred (nearer than the near point),
//!   the card sharp, the chart blurred (beyond the far point). Glasses:
//!   Fig. 8(c)'s concave lens, −0.77 D (far point to infinity), n = 1.66.
//! * Knobs: `S` (clones) in the series marked "knob S"; the field's
//!   resolution (× the paper's 110×77×42 voxels and 1,537 bundles) in the
//!   series marked "knob scale".
//! * Reference: the same scene through the same eye with `S = 128` clones
//!   shaded in full (the paper's accumulation over pupil samples, each
//!   point at its own best accommodation), through the glasses with the
//!   field at twice the paper's resolution per axis (quick: the paper's).
//!   `psnr_db` and `flip_mean` of the displayed (tonemapped 8-bit) views.
//! * Time: the lit frame with the eye against the lit frame without it
//!   (`baseline_time_ms`), medians over the timed frames.
//! * Bevy's own `DepthOfField` (Gaussian, bokeh) in the same run: focused
//!   on the card (in the eye's sharp zone) with the eye's aperture (f-number
//!   = the lens's focal length over 12 mm, so its blur angle is the eye's
//!   `A·ΔD` for one focal plane), against the same reference and timed the
//!   same way: what a Bevy user would reach for instead.
//! * Mechanism: `S` cameras, each drawing the lit scene shaded into its own
//!   target (what one camera per clone costs at least, displacement left
//!   out), against the plugin's one clone camera with an atlas (the series
//!   "full shading").

use bevy::camera::Hdr;
use bevy::post_process::dof::{DepthOfField, DepthOfFieldMode};
use bevy::prelude::*;
use optica_harness::PairedTimings;
use bevy::render::view::Msaa;
use optica_harness::textures::checker;
use optica_harness::{RenderedFrame, metrics};
use optica_spectacles::{
    CloneDefocus, CloneShading, Eye, FieldBox, LensMaterial, Spectacles, SpectaclesPlugin,
};

use super::SweepError;
use crate::fixtures::clearing_camera;
use crate::{Report, Row, SweepContext};

const FOV: f32 = 0.8;
const NEAR_M: f32 = 0.5;
const FAR_M: f32 = 1.3;
const PUPIL_MM: f32 = 12.0;
/// Fig. 8(c)'s concave lens: the far point (1.3 m from the pupil, 1.285 m
/// from a lens 15 mm in front of it) to infinity.
pub(super) const CONCAVE_D: f32 = -0.778;

/// What looks at the room.
#[derive(Clone)]
pub(super) enum Viewer {
    Sharp,
    Eye {
        defocus: CloneDefocus,
        glasses: bool,
    },
    BevyDof(DepthOfFieldMode),
    /// `S` plain cameras, each drawing the scene into its own target.
    Cameras(u32),
    /// A camera with glasses and no eye: the lens's refraction alone.
    Lens(Spectacles),
}

/// The lit room through `spectacles`, no eye (the refraction's rows).
pub(crate) fn room_with(spectacles: Spectacles) -> impl FnOnce(&mut App) {
    room(Viewer::Lens(spectacles), true)
}

pub(super) fn eye() -> Eye {
    Eye::from_near_far(NEAR_M, FAR_M, PUPIL_MM)
}

pub(super) fn defocus(clones: u32, shading: CloneShading, field_scale: f32) -> CloneDefocus {
    let paper = FieldBox::default();
    let sc = |n: u32| ((n as f32 * field_scale).round() as u32).max(1);
    CloneDefocus {
        clones,
        shading,
        field: FieldBox {
            voxels: UVec3::new(sc(paper.voxels.x), sc(paper.voxels.y), sc(paper.voxels.z)),
            aims: UVec2::new(sc(paper.aims.x), sc(paper.aims.y).max(3)),
            ..paper
        },
        ..default()
    }
}

/// The room seen by `viewer`, lit or not.
pub(super) fn room(viewer: Viewer, lit: bool) -> impl FnOnce(&mut App) {
    move |app: &mut App| {
        app.add_plugins(SpectaclesPlugin);
        app.add_systems(
            Startup,
            move |mut commands: Commands,
                  mut meshes: ResMut<Assets<Mesh>>,
                  mut images: ResMut<Assets<Image>>,
                  mut materials: ResMut<Assets<StandardMaterial>>| {
                // (distance, size, offset, cells)
                let targets = [
                    (5.0, 4.4, Vec2::new(0.0, 0.3), 16),
                    (1.0, 0.5, Vec2::new(0.22, -0.05), 8),
                    (0.3, 0.12, Vec2::new(-0.07, -0.06), 8),
                ];
                for (distance, size, offset, cells) in targets {
                    let material = materials.add(StandardMaterial {
                        base_color_texture: Some(images.add(checker(256, cells, 20, 230))),
                        unlit: !lit,
                        perceptual_roughness: 0.6,
                        ..default()
                    });
                    commands.spawn((
                        Mesh3d(
                            meshes.add(
                                Plane3d::new(Vec3::Z, Vec2::splat(0.5 * size))
                                    .mesh()
                                    .subdivisions(15),
                            ),
                        ),
                        MeshMaterial3d(material),
                        Transform::from_xyz(offset.x, offset.y, -distance),
                    ));
                }
                if lit {
                    commands.spawn((
                        Mesh3d(
                            meshes.add(Plane3d::new(Vec3::Y, Vec2::splat(6.0)).mesh().subdivisions(31)),
                        ),
                        MeshMaterial3d(materials.add(StandardMaterial::from_color(Color::srgb(0.5, 0.45, 0.4)))),
                        Transform::from_xyz(0.0, -0.6, -3.0),
                    ));
                    commands.spawn((
                        DirectionalLight {
                            illuminance: 8_000.0,
                            shadow_maps_enabled: true,
                            ..default()
                        },
                        Transform::from_xyz(1.0, 2.0, 1.0).looking_at(Vec3::new(0.0, 0.0, -2.0), Vec3::Y),
                    ));
                }
                let camera = clearing_camera(Color::srgb(0.35, 0.4, 0.5), FOV, 0.05);
                match &viewer {
                    Viewer::Sharp => {
                        commands.spawn(camera);
                    }
                    Viewer::Eye { defocus, glasses } => {
                        let mut c = commands.spawn((camera, eye(), defocus.clone()));
                        if *glasses {
                            c.insert(Spectacles {
                                material: LensMaterial::Paper,
                                ..Spectacles::sphere(CONCAVE_D)
                            });
                        }
                    }
                    Viewer::BevyDof(mode) => {
                        // A thin lens of the camera's focal length with the
                        // eye's aperture: its blur angle is A·ΔD about one
                        // focal plane, the card's.
                        let sensor = DepthOfField::default().sensor_height;
                        let focal = sensor / (2.0 * (0.5 * FOV).tan());
                        commands.spawn((
                            camera,
                            Hdr,
                            DepthOfField {
                                mode: *mode,
                                focal_distance: 1.0,
                                aperture_f_stops: focal / (PUPIL_MM * 1e-3),
                                ..default()
                            },
                        ));
                    }
                    Viewer::Lens(s) => {
                        commands.spawn((camera, s.clone()));
                    }
                    Viewer::Cameras(n) => {
                        commands.spawn(camera);
                        for _ in 1..*n {
                            let target = images.add(Image::new_target_texture(
                                256,
                                256,
                                bevy::render::render_resource::TextureFormat::Rgba16Float,
                                None,
                            ));
                            commands.spawn((
                                Camera3d::default(),
                                Camera {
                                    order: -1,
                                    ..default()
                                },
                                Hdr,
                                Msaa::Off,
                                bevy::camera::RenderTarget::Image(target.into()),
                                Projection::Perspective(PerspectiveProjection {
                                    fov: FOV,
                                    near: 0.05,
                                    ..default()
                                }),
                            ));
                        }
                    }
                }
            },
        );
    }
}

/// PSNR (dB) and mean ꟻLIP of `frame` against `reference`.
fn error(reference: &RenderedFrame, frame: &RenderedFrame) -> Result<(f64, f64), SweepError> {
    let (r, f) = (reference.to_rgba8(), frame.to_rgba8());
    let m = metrics::compare(&r, &f).map_err(|e| SweepError::Setup(format!("{e:?}")))?;
    Ok((m.psnr_db, m.flip_mean))
}

/// The frames a render runs: the clone rig appears on the second, the eye
/// camera's depth is readable from the third.
const FRAMES: u32 = 6;

/// Adds the rendered series to `report`.
pub fn rendered_rows(ctx: &SweepContext, report: &mut Report) -> Result<(), SweepError> {
    let (size, big) = ctx.pick((128, 256), (256, 512));
    let timing = ctx.pick((2, 3), (5, 15));
    let clone_counts: Vec<u32> = ctx.pick(vec![4, 10], vec![4, 10, 20, 40]);
    let reference_clones = ctx.pick(32, 128);
    let reference_scale = ctx.pick(1.0, 2.0);
    let scales: Vec<f32> = ctx.pick(vec![0.5], vec![0.25, 0.5, 1.0]);
    let total = 2 + 3 * clone_counts.len() + scales.len() + 4;
    let mut step = 0;
    let mut progress = |note: &str| {
        step += 1;
        ctx.progress(step, total, note);
    };

    let render = |viewer: Viewer| -> Result<RenderedFrame, SweepError> {
        Ok(ctx.headless(size, size).frames(FRAMES).render(room(viewer, false))?)
    };
    // Each view against the sharp view, in alternating blocks.
    let (blocks, per_block) = ctx.blocks();
    let time = |viewer: Viewer, px: u32| -> Result<PairedTimings, SweepError> {
        Ok(ctx.headless(px, px).time_paired(
            timing.0 + FRAMES,
            blocks,
            per_block,
            room(viewer, true),
            room(Viewer::Sharp, true),
        )?)
    };

    progress("references");
    let naked_ref = render(Viewer::Eye {
        defocus: defocus(reference_clones, CloneShading::Full, 1.0),
        glasses: false,
    })?;
    report.adapter.get_or_insert(naked_ref.adapter.clone());
    let glasses_ref = render(Viewer::Eye {
        defocus: defocus(reference_clones, CloneShading::Full, reference_scale),
        glasses: true,
    })?;
    progress("sharp frames");
    // The sharp view against itself: the interval that noise alone gives.
    let sharp_pair = time(Viewer::Sharp, size)?;
    let sharp = render(Viewer::Sharp)?;
    let (sharp_psnr, sharp_flip) = error(&naked_ref, &sharp)?;
    report.rows.push(
        Row::paired(0.0, &sharp_pair)
            .series("rendered: no eye (sharp), against the naked reference")
            .err("psnr_db", sharp_psnr)
            .err("flip_mean", sharp_flip)
            .work("size_px", f64::from(size)),
    );

    for &s in &clone_counts {
        for (name, shading) in [
            ("reprojected", CloneShading::Reprojected),
            ("full shading", CloneShading::Full),
        ] {
            progress(&format!("naked, {name}, S = {s}"));
            let viewer = Viewer::Eye {
                defocus: defocus(s, shading, 1.0),
                glasses: false,
            };
            let (psnr, flip) = error(&naked_ref, &render(viewer.clone())?)?;
            let timed = time(viewer, size)?;
            report.rows.push(
                Row::paired(f64::from(s), &timed)
                    .series(&format!("rendered: naked, {name} (knob S)"))
                    .err("psnr_db", psnr)
                    .err("flip_mean", flip)
                    .work("clones", f64::from(s))
                    .work("frame_ratio", timed.ratio.median)
                    .work("size_px", f64::from(size)),
            );
        }
        progress(&format!("glasses, reprojected, S = {s}"));
        let viewer = Viewer::Eye {
            defocus: defocus(s, CloneShading::Reprojected, 1.0),
            glasses: true,
        };
        let (psnr, flip) = error(&glasses_ref, &render(viewer.clone())?)?;
        let timed = time(viewer, size)?;
        report.rows.push(
            Row::paired(f64::from(s), &timed)
                .series("rendered: −0.78 D glasses, reprojected (knob S)")
                .err("psnr_db", psnr)
                .err("flip_mean", flip)
                .work("clones", f64::from(s))
                .work("frame_ratio", timed.ratio.median)
                .work("size_px", f64::from(size)),
        );
    }

    for &k in &scales {
        progress(&format!("glasses, field scale {k}"));
        let viewer = Viewer::Eye {
            defocus: defocus(10, CloneShading::Reprojected, k),
            glasses: true,
        };
        let (psnr, flip) = error(&glasses_ref, &render(viewer.clone())?)?;
        let timed = time(viewer, size)?;
        report.rows.push(
            Row::paired(f64::from(k), &timed)
                .series("rendered: −0.78 D glasses, S = 10 (knob scale)")
                .err("psnr_db", psnr)
                .err("flip_mean", flip)
                .work("field_scale", f64::from(k))
                .work("frame_ratio", timed.ratio.median)
                .work("size_px", f64::from(size)),
        );
    }

    for (name, mode) in [
        ("gaussian", DepthOfFieldMode::Gaussian),
        ("bokeh", DepthOfFieldMode::Bokeh),
    ] {
        progress(&format!("Bevy DepthOfField, {name}"));
        let viewer = Viewer::BevyDof(mode);
        let (psnr, flip) = error(&naked_ref, &render(viewer.clone())?)?;
        let timed = time(viewer, size)?;
        report.rows.push(
            Row::paired(0.0, &timed)
                .series(&format!("rendered: Bevy DepthOfField {name}, focus 1 m, against the naked reference"))
                .err("psnr_db", psnr)
                .err("flip_mean", flip)
                .work("frame_ratio", timed.ratio.median)
                .work("size_px", f64::from(size)),
        );
    }

    progress("S cameras");
    let timed = time(Viewer::Cameras(10), size)?;
    report.rows.push(
        Row::paired(10.0, &timed)
            .series("mechanism: S cameras, each drawing the scene shaded (knob S)")
            .work("frame_ratio", timed.ratio.median)
            .work("size_px", f64::from(size)),
    );

    progress(&format!("{big}²"));
    let big_timed = time(
        Viewer::Eye {
            defocus: defocus(10, CloneShading::Reprojected, 1.0),
            glasses: true,
        },
        big,
    )?;
    report.rows.push(
        Row::paired(10.0, &big_timed)
            .series(&format!("rendered at {big}²: −0.78 D glasses, reprojected (knob S)"))
            .work("frame_ratio", big_timed.ratio.median)
            .work("size_px", f64::from(big)),
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quick_rendered_rows_follow_the_reference() {
        let ctx = SweepContext::new("spectacles", true, true);
        let mut report = Report::cpu("spectacles", "resolution_scale");
        rendered_rows(&ctx, &mut report).expect("the rendered rows run on lavapipe");
        let rows = &report.rows;
        for r in rows {
            eprintln!("{} {}: {:?}, {:.1} ms vs {:.1} ms", r.series, r.knob, r.error, r.time_ms, r.baseline_time_ms);
        }
        assert!(report.problems().is_empty(), "{:?}", report.problems());
        let flip = |series: &str, knob: f64| {
            rows.iter()
                .find(|r| r.series.contains(series) && r.knob == knob)
                .unwrap_or_else(|| panic!("no `{series}` row at {knob}"))
                .error["flip_mean"]
        };
        let sharp = flip("no eye", 0.0);
        // Every rendering of the eye is nearer the reference than the
        // sharp view, and nearer with more clones.
        for series in ["naked, reprojected", "naked, full shading", "glasses, reprojected"] {
            assert!(flip(series, 10.0) < sharp, "{series}");
            assert!(flip(series, 10.0) < flip(series, 4.0), "{series}");
        }
        // Bevy's one focal plane cannot show the eye's sharp zone.
        assert!(flip("DepthOfField gaussian", 0.0) > flip("naked, reprojected", 10.0));
    }
}
