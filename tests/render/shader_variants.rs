//! Every WGSL shader of the five plugins and every shader-def variant a
//! scene can select, built as a pipeline on wgpu's noop backend (naga
//! validates each shader there, with no driver): one list, so that a
//! variant a driver cannot compile is still validated, and a new variant is
//! added here. Mesa 25's lavapipe compiles all of them; Mesa 22.3's
//! crashes on the compound eye's deferred G-buffer variant.
//!
//! | plugin | shader | variants (what selects them) |
//! |---|---|---|
//! | lens flare | `ghost_trace`, `ghost_cells` | one each |
//! | lens flare | `ghost_draw` | round iris / `BLADED_IRIS` (blades); the starburst entry |
//! | lens flare | `upsample` | ghosts at a reduced resolution |
//! | lens flare | occlusion | single-sampled / `MULTISAMPLED` depth (MSAA) |
//! | dome | `cube_resample` | cube mode |
//! | dome | the rim mask (Bevy's full-screen material) | fisheye lenses |
//! | dome | Bevy's view shader, patched | vertex mode |
//! | dome | Bevy's `pbr_fragment`, patched (exact attributes) | forward; deferred; with UVs, tangents and colours |
//! | foveated LOD | `raytrace` | `trace_mid`, `trace_outer`, `trace_full` (`TRACE`), the blit |
//! | spectacles | `resolve` | reprojected / `FULL` / `MULTISAMPLED` |
//! | spectacles | `lens_refraction` | the copy and the lens draw |
//! | spectacles | `clone` (+ `clone_vertex`, `field_lookup`, `displacement`) | full shading / `REPROJECTED` |
//! | spectacles | `mirror` | the mirror material; the march (`MARCH`, `MULTISAMPLED`) |
//! | compound eye | `compound_eye` (+ `compound_eye_optics`) | forward, prepass, deferred |

use bevy::prelude::*;
use bevy::render::view::Msaa;
use optica_harness::PipelineReport;

fn build(setup: impl FnOnce(&mut App)) -> PipelineReport {
    crate::noop_pipelines(4, setup)
}

/// How many pipelines with `label` the report holds.
fn count(report: &PipelineReport, label: &str) -> usize {
    report.labels.iter().filter(|l| *l == label).count()
}

fn assert_labels(what: &str, report: &PipelineReport, expected: &[(&str, usize)]) {
    for &(label, at_least) in expected {
        let n = count(report, label);
        assert!(
            n >= at_least,
            "{what}: {n} × {label}, expected {at_least}; built: {:?}",
            report.labels
        );
    }
}

#[test]
fn every_shader_variant_builds_on_noop() {
    lens_flare_variants();
    dome_variants();
    tracer_variants();
    spectacles_variants();
    compound_eye_variants();
}

/// Lens flare: a round and a bladed iris, the starburst, ghosts at a
/// quarter of the resolution (upsampled), occlusion with and without
/// MSAA.
fn lens_flare_variants() {
    let flare = build(|app: &mut App| {
        use optica_lens_flare::{LensFlare, LensFlarePlugin};
        app.add_plugins(LensFlarePlugin);
        app.add_systems(
            Startup,
            |mut commands: Commands, assets: Res<AssetServer>| {
                commands.spawn(crate::lens_flare::sun(
                    Vec3::new(0.1, 0.1, 1.0).normalize(),
                    100_000.0,
                ));
                for (blades, msaa, order) in [(0, Msaa::Off, 0), (6, Msaa::Sample4, 1)] {
                    let mut flare = LensFlare {
                        grid: 8,
                        ..LensFlare::new(assets.load("lenses/tessar-us2854889.lens"))
                    };
                    flare.aperture.blades = blades;
                    commands
                        .spawn((crate::lens_flare::black_hdr_camera(), flare))
                        .insert((msaa, Camera { order, ..default() }));
                }
            },
        );
    });
    assert_labels(
        "lens flare",
        &flare,
        &[
            ("optica_lens_flare_trace", 1),
            ("optica_lens_flare_cells", 1),
            ("optica_lens_flare_draw", 2),
            ("optica_lens_flare_starburst", 1),
            ("optica_lens_flare_upsample", 1),
            ("optica_lens_flare_occlusion", 2),
        ],
    );
}

/// Dome: vertex and cube mode, a fisheye (rim mask) and the panorama.
fn dome_variants() {
    let dome = build(|app: &mut App| {
        use optica_dome::{DomeCamera, DomeLens, DomeMode};
        let z = optica_report::fixtures::zenith();
        optica_report::fixtures::dome_room([Color::WHITE; 6], 1, move |commands| {
            commands.spawn((DomeCamera::default(), z));
            commands.spawn((
                DomeCamera {
                    mode: DomeMode::CubeMap { face_px: 16 },
                    lens: DomeLens::Equirectangular,
                    ..default()
                },
                Camera {
                    order: 1,
                    ..default()
                },
                z,
            ));
        })(app);
    });
    assert_labels(
        "dome",
        &dome,
        &[
            ("optica_dome_cube_resample", 1),
            (
                "fullscreen_material_pipeline<optica_dome::mask::DomeRimMask>",
                1,
            ),
        ],
    );
    // The exact-attribute step in every fragment that reads Bevy's vertex
    // output through `pbr_input_from_standard_material`: forward (beside a
    // normal prepass, whose own fragment does not read it), and the
    // deferred G-buffer (the prepass `VertexOutput`), on a mesh with UVs,
    // tangents and colours (each field of the step's own `#ifdef`).
    for deferred in [false, true] {
        let report = build(move |app: &mut App| {
            use bevy::core_pipeline::prepass::{DepthPrepass, NormalPrepass};
            use optica_dome::DomeCamera;
            let z = optica_report::fixtures::zenith();
            optica_report::fixtures::dome_room([Color::WHITE; 6], 1, move |commands| {
                commands.spawn((DomeCamera::default(), DepthPrepass, NormalPrepass, z));
            })(app);
            app.add_systems(
                Startup,
                |mut commands: Commands,
                 mut meshes: ResMut<Assets<Mesh>>,
                 mut materials: ResMut<Assets<StandardMaterial>>| {
                    let mut mesh = Sphere::new(0.3)
                        .mesh()
                        .uv(12, 6)
                        .with_generated_tangents()
                        .expect("tangents");
                    let colours = vec![[1.0f32, 0.5, 0.2, 1.0]; mesh.count_vertices()];
                    mesh.insert_attribute(Mesh::ATTRIBUTE_COLOR, colours);
                    commands.spawn((
                        Mesh3d(meshes.add(mesh)),
                        MeshMaterial3d(materials.add(StandardMaterial::default())),
                        Transform::from_xyz(0.0, 0.5, 0.0),
                    ));
                },
            );
            if deferred {
                crate::compound_eye::deferred(app);
            }
        });
        assert!(report.ok > 0, "dome (deferred {deferred}): nothing built");
    }
}

/// Foveated LOD: the three trace entries and the blit.
fn tracer_variants() {
    let tracer = build(|app: &mut App| {
        use optica_foveated_lod::{
            FoveatedLodPlugin, GazeRayTracer, HeadSource, RayTraced, TrackedHead,
        };
        let eye = Vec3::new(0.0, 0.8, 3.0);
        app.add_plugins(FoveatedLodPlugin)
            .insert_resource(HeadSource::External)
            // Gazing aside: the view has a central field, a periphery and
            // an outer layer.
            .insert_resource(TrackedHead::looking(
                eye,
                Quat::IDENTITY,
                Some(Vec3::new(-0.8, -0.2, -1.0).normalize()),
                0.063,
            ))
            .add_systems(
                Startup,
                move |mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>| {
                    commands.spawn((
                        Mesh3d(meshes.add(Sphere::new(0.5).mesh().ico(1).unwrap())),
                        RayTraced::diffuse(LinearRgba::WHITE),
                    ));
                    commands.spawn((
                        GazeRayTracer::default(),
                        Transform::from_translation(eye).looking_at(Vec3::ZERO, Vec3::Y),
                    ));
                },
            );
    });
    assert_labels(
        "foveated LOD",
        &tracer,
        &[
            ("optica_foveated_lod_trace_mid", 1),
            ("optica_foveated_lod_trace_outer", 1),
            ("optica_foveated_lod_trace_full", 1),
            ("optica_foveated_lod_blit", 1),
        ],
    );
}

/// Spectacles (one eye draws clones at a time, so an app each): a
/// reprojected eye with glasses refracting the view and a mirror, one
/// shaded in full, one reprojected with MSAA.
fn spectacles_variants() {
    for (shading, msaa, glasses) in [
        (
            optica_spectacles::CloneShading::Reprojected,
            Msaa::Off,
            true,
        ),
        (optica_spectacles::CloneShading::Full, Msaa::Off, false),
        (
            optica_spectacles::CloneShading::Reprojected,
            Msaa::Sample4,
            false,
        ),
    ] {
        let spectacles = build(move |app: &mut App| {
            use optica_spectacles::{CloneDefocus, CurvedMirror, Eye, MirrorViewer, Spectacles};
            crate::spectacles::scene(
                vec![crate::spectacles::Target::checker(2.0, 1.0, 4)],
                Some((
                    Eye {
                        refractive_error_d: -3.0,
                        ..default()
                    },
                    CloneDefocus {
                        clones: 4,
                        shading,
                        ..default()
                    },
                )),
                glasses.then(|| Spectacles::sphere(-2.0)),
                0.8,
            )(app);
            app.add_systems(
                PostStartup,
                move |mut commands: Commands, eyes: Query<Entity, With<Eye>>| {
                    for eye in &eyes {
                        commands.entity(eye).insert(msaa);
                        if glasses {
                            commands.entity(eye).insert(MirrorViewer);
                        }
                    }
                    if glasses {
                        commands.spawn((
                            CurvedMirror::default(),
                            Transform::from_xyz(0.0, 0.0, -1.0).looking_at(Vec3::ZERO, Vec3::Y),
                        ));
                    }
                },
            );
        });
        let what = format!("spectacles ({shading:?}, {msaa:?})");
        let mut expected = vec![("optica_spectacles_resolve", 1)];
        if glasses {
            expected.extend([
                ("optica_spectacles_lens_copy", 1),
                ("optica_spectacles_lens_draw", 1),
                ("optica_spectacles_lens_march", 1),
            ]);
        }
        assert_labels(&what, &spectacles, &expected);
    }
}

/// Compound eye: forward, and the deferred renderer's G-buffer variant
/// (the one lavapipe cannot compile) with its prepass: more pipelines
/// than the same scene with the plain material alone.
fn compound_eye_variants() {
    let eye_scene = |eye: bool, deferred: bool| {
        build(move |app: &mut App| {
            let material = eye.then(|| optica_compound_eye::CompoundEye::default());
            crate::compound_eye::scene(
                Sphere::new(1.0).mesh().uv(16, 8),
                Transform::IDENTITY,
                material,
                Transform::from_xyz(0.0, 0.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
                Projection::default(),
            )(app);
            // A plain sphere beside it: with the eye, the material's own
            // pipelines are built besides the plain ones.
            app.add_systems(
                Startup,
                |mut commands: Commands,
                 mut meshes: ResMut<Assets<Mesh>>,
                 mut materials: ResMut<Assets<StandardMaterial>>| {
                    commands.spawn((
                        Mesh3d(meshes.add(Sphere::new(0.5).mesh().uv(16, 8))),
                        MeshMaterial3d(materials.add(crate::compound_eye::base())),
                        Transform::from_xyz(1.5, 0.0, 0.0),
                    ));
                },
            );
            if deferred {
                crate::compound_eye::deferred(app);
            }
        })
    };
    for deferred in [false, true] {
        let (with, plain) = (eye_scene(true, deferred), eye_scene(false, deferred));
        assert!(
            with.ok > plain.ok,
            "compound eye (deferred {deferred}): {} pipelines, {} without it",
            with.ok,
            plain.ok
        );
    }
}
