//! The lens flare scene: a low sun at dusk over a field of pillars and
//! three coloured lamps, seen through a real lens (the coated Brendel
//! Tessar by default); the camera pans slowly so the ghosts slide through
//! the picture along the line through the sun and the centre.

// Each example uses part of this file; the showcase uses all of it.
#![allow(dead_code)]

use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::prelude::*;
#[cfg(feature = "egui")]
use optica::lens_flare::{DEFAULT_COARSE_GHOST_PX, FlareGhosts, GhostResolution};
use optica::lens_flare::{FlareSource, LensFlare, LensFlarePlugin};

use super::common::SceneEntity;

/// The scene's name in file names and on the command line.
pub const NAME: &str = "lens_flare";
/// The picture's size in a window of its own.
pub const SIZE: (u32, u32) = (960, 540);
/// Pan rate of the camera, radians per second.
const PAN: f32 = 0.08;

/// The shipped lenses, embedded in the plugin: (name, asset path).
pub use optica::lens_flare::lenses::ALL as LENSES;

/// What the scene starts with: the lens (an index into [`LENSES`]) and
/// the pan's clock (s).
#[derive(Resource, Clone, Debug, Default)]
pub struct FlareScene {
    /// Index into [`LENSES`].
    pub lens: usize,
    /// The pan's clock, seconds (real time in a window, fixed for snapshots).
    pub clock: f32,
}

/// Adds the plugin and the pan (it moves only this scene's camera).
pub fn build(app: &mut App) {
    app.add_plugins(LensFlarePlugin)
        .init_resource::<FlareScene>()
        .add_systems(Update, pan);
}

/// Runs the pan's clock in real time (a window).
pub fn run_clock(app: &mut App) {
    app.add_systems(First, |time: Res<Time>, mut scene: ResMut<FlareScene>| {
        scene.clock = time.elapsed_secs();
    });
}

pub fn spawn(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    assets: Res<AssetServer>,
    scene: Res<FlareScene>,
) {
    commands.insert_resource(ClearColor(Color::srgb(0.04, 0.06, 0.14)));
    commands.insert_resource(GlobalAmbientLight::default());
    commands.spawn((
        SceneEntity,
        Mesh3d(meshes.add(Plane3d::default().mesh().size(400.0, 400.0))),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::srgb(0.25, 0.3, 0.2),
            perceptual_roughness: 0.9,
            ..default()
        })),
    ));
    let stone = materials.add(StandardMaterial {
        base_color: Color::srgb(0.6, 0.58, 0.55),
        ..default()
    });
    let pillar = meshes.add(Cuboid::new(2.0, 14.0, 2.0));
    for k in 0..9 {
        let a = -0.9 + 0.22 * k as f32;
        let d = 30.0 + 8.0 * (k % 3) as f32;
        commands.spawn((
            SceneEntity,
            Mesh3d(pillar.clone()),
            MeshMaterial3d(stone.clone()),
            Transform::from_xyz(d * a.sin(), 7.0, -d * a.cos()),
        ));
    }
    // A low sun ahead, a little to the right, and its disc on the sky.
    let travel = Vec3::new(-0.3, -0.13, 1.0).normalize();
    commands.spawn((
        SceneEntity,
        DirectionalLight {
            illuminance: 8_000.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::IDENTITY.looking_to(travel, Vec3::Y),
        FlareSource::default(),
    ));
    commands.spawn((
        SceneEntity,
        Mesh3d(meshes.add(Sphere::new(3.0))),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::BLACK,
            emissive: LinearRgba::rgb(400.0, 300.0, 200.0),
            ..default()
        })),
        Transform::from_translation(-travel * 300.0),
    ));
    // Three lamps: they flare too.
    for (k, colour) in [
        Color::srgb(1.0, 0.5, 0.2),
        Color::srgb(0.3, 1.0, 0.4),
        Color::srgb(0.4, 0.5, 1.0),
    ]
    .into_iter()
    .enumerate()
    {
        commands.spawn((
            SceneEntity,
            PointLight {
                intensity: 4.0e5,
                range: 60.0,
                color: colour,
                ..default()
            },
            Transform::from_xyz(-8.0 + 8.0 * k as f32, 3.0, -14.0),
            FlareSource::default(),
        ));
    }
    commands.spawn((
        SceneEntity,
        Camera3d::default(),
        Tonemapping::TonyMcMapface,
        Transform::from_xyz(0.0, 1.7, 6.0),
        LensFlare {
            // Dusk light is dim; the ghosts are scaled up to show.
            intensity: 150.0,
            ..LensFlare::new(assets.load(LENSES[scene.lens].1))
        },
    ));
}

/// Pans the camera left and right with the clock.
fn pan(scene: Res<FlareScene>, mut cameras: Query<&mut Transform, With<LensFlare>>) {
    for mut t in &mut cameras {
        let yaw = 0.25 * (PAN * scene.clock * 4.0).sin();
        t.rotation = Quat::from_rotation_y(yaw) * Quat::from_rotation_x(0.08);
    }
}

/// The flare's settings.
#[cfg(feature = "egui")]
pub fn panel(
    mut contexts: bevy_egui::EguiContexts,
    mut cameras: Query<(&mut LensFlare, Option<&FlareGhosts>)>,
    assets: Res<AssetServer>,
    diagnostics: Res<bevy::diagnostic::DiagnosticsStore>,
) -> Result {
    use bevy_egui::egui;
    let Ok((mut flare, ghosts)) = cameras.single_mut() else {
        return Ok(());
    };
    let mut edit = flare.clone();
    egui::Window::new("Lens flare").show(contexts.ctx_mut()?, |ui| {
        let current = LENSES
            .iter()
            .position(|(_, path)| {
                assets
                    .get_path(edit.lens.id())
                    .is_some_and(|p| p.path().ends_with(path))
            })
            .unwrap_or(0);
        egui::ComboBox::from_label("lens")
            .selected_text(LENSES[current].0)
            .show_ui(ui, |ui| {
                for (name, path) in LENSES {
                    if ui
                        .selectable_label(LENSES[current].1 == path, name)
                        .clicked()
                    {
                        edit.lens = assets.load(path);
                    }
                }
            });
        ui.add(
            egui::Slider::new(&mut edit.grid, 4..=128)
                .logarithmic(true)
                .text("rays per side"),
        );
        ui.checkbox(
            &mut edit.adaptive_grid,
            "rays shared by power (mean per side above)",
        );
        ui.checkbox(&mut edit.symmetry, "trace half by symmetry");
        ui.horizontal(|ui| {
            ui.label("ghosts added up at");
            for (resolution, name) in [
                (GhostResolution::Full, "full"),
                (GhostResolution::Half, "half"),
                (GhostResolution::Quarter, "quarter"),
            ] {
                ui.radio_value(&mut edit.ghost_resolution, resolution, name);
            }
            ui.label("resolution");
        });
        ui.add(egui::Slider::new(&mut edit.wavelengths, 1..=8).text("wavelengths"));
        ui.add(
            egui::Slider::new(&mut edit.merge_wavelengths_px, 0.0..=4.0)
                .text("merge wavelengths below (px)"),
        );
        let mut coarse = edit.coarse_ghost_px.is_some();
        ui.checkbox(&mut coarse, "large ghosts at half that resolution");
        if coarse {
            let mut px = edit.coarse_ghost_px.unwrap_or(DEFAULT_COARSE_GHOST_PX);
            ui.add(
                egui::Slider::new(&mut px, 0.0..=256.0)
                    .text("when wider than (px of the ghosts' target)"),
            );
            edit.coarse_ghost_px = Some(px);
        } else {
            edit.coarse_ghost_px = None;
        }
        ui.add(egui::Slider::new(&mut edit.aperture.blades, 0..=12).text("blades (0: round)"));
        ui.add(egui::Slider::new(&mut edit.aperture.roundness, 0.0..=1.0).text("blade roundness"));
        let mut stopped = edit.aperture.f_number.is_some();
        ui.checkbox(&mut stopped, "stopped down");
        if stopped {
            let mut f = edit.aperture.f_number.unwrap_or(8.0);
            ui.add(
                egui::Slider::new(&mut f, 1.0..=32.0)
                    .logarithmic(true)
                    .text("f-number"),
            );
            edit.aperture.f_number = Some(f);
        } else {
            edit.aperture.f_number = None;
        }
        let mut coated = edit.coating.is_some();
        ui.checkbox(&mut coated, "MgF₂ coating on every air surface");
        edit.coating = coated.then(|| edit.coating.unwrap_or_default());
        ui.add(
            egui::Slider::new(&mut edit.ghost_budget, 1..=528)
                .logarithmic(true)
                .text("ghost budget"),
        );
        ui.add(
            egui::Slider::new(&mut edit.intensity, 0.1..=1000.0)
                .logarithmic(true)
                .text("intensity"),
        );
        let mut occluded = edit.occlusion.is_some();
        ui.checkbox(&mut occluded, "occlusion by depth");
        edit.occlusion = occluded.then(|| edit.occlusion.unwrap_or_default());
        let mut burst = edit.starburst.is_some();
        ui.checkbox(&mut burst, "starburst");
        edit.starburst = burst.then(|| edit.starburst.unwrap_or_default());
        if let Some(b) = edit.starburst.as_mut() {
            ui.add(egui::Slider::new(&mut b.size, 0.02..=1.0).text("starburst size"));
            ui.add(
                egui::Slider::new(&mut b.intensity, 1e-5..=0.1)
                    .logarithmic(true)
                    .text("starburst share"),
            );
            ui.add(egui::Slider::new(&mut b.specks, 0..=400).text("dust specks"));
            ui.add(egui::Slider::new(&mut b.scratches, 0..=40).text("scratches"));
        }
        let mut ringing = edit.ringing.is_some();
        ui.checkbox(&mut ringing, "ringing");
        edit.ringing = ringing.then(|| edit.ringing.unwrap_or_default());
        if let Some(r) = edit.ringing.as_mut() {
            ui.add(
                egui::Slider::new(&mut r.fresnel_number, 1.0..=1000.0)
                    .logarithmic(true)
                    .text("Fresnel number"),
            );
        }
        if let Err(e) = edit.validate() {
            ui.colored_label(egui::Color32::from_rgb(230, 120, 60), e.to_string());
        }
        if let Some(g) = ghosts {
            ui.label(format!(
                "{} of {} ghosts drawn, {} rays per light and wavelength",
                g.drawn().count(),
                g.ghosts.len(),
                g.rays_per_light()
            ));
            if let Some(p) = &g.problem {
                ui.colored_label(egui::Color32::from_rgb(230, 120, 60), p.to_string());
            }
        }
        // The flare's passes on the GPU (where the adapter has timestamp
        // queries) against the whole frame.
        let smoothed = |path: &'static str| {
            diagnostics
                .get(&bevy::diagnostic::DiagnosticPath::const_new(path))
                .and_then(|d| d.smoothed())
        };
        let frame = smoothed("fps").map(|fps| 1000.0 / fps.max(1e-3));
        match (smoothed("render/optica/lens_flare/elapsed_gpu"), frame) {
            (Some(flare), Some(frame)) => ui.label(format!(
                "flare {flare:.2} ms of a {frame:.1} ms frame ({:.0} %)",
                100.0 * flare / frame
            )),
            _ => ui.label("flare time: no GPU timestamps on this adapter"),
        };
    });
    if edit != *flare {
        *flare = edit;
    }
    Ok(())
}
