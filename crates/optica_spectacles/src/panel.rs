//! A settings panel (cargo feature `egui`).
//!
//! [`spectacles_ui`] draws an eye camera's [`Eye`], [`Spectacles`] and
//! [`CloneDefocus`], the presets and what the plugin made of them
//! ([`SpectaclesStatus`]) into an egui `Ui` of yours;
//! [`SpectaclesPanelPlugin`] shows it in a window for the first eye camera,
//! and [`mirror_ui`] for the first [`CurvedMirror`] in another.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use bevy_egui::EguiPlugin;
//! use optica_spectacles::{Eye, SpectaclesPanelPlugin, SpectaclesPlugin};
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, EguiPlugin::default(), SpectaclesPlugin, SpectaclesPanelPlugin))
//!     .add_systems(Startup, |mut commands: Commands| {
//!         commands.spawn((Camera3d::default(), Eye::default()));
//!     })
//!     .run();
//! ```

use optica_plugin_kit::slider;

use bevy::prelude::*;
use bevy_egui::{EguiContexts, EguiPrimaryContextPass, egui};

use crate::SpectaclesStatus;
use crate::mirror::MirrorState;
use crate::settings::{CurvedMirror, MirrorMethod};
use crate::presets::presets;
use crate::settings::{
    Accommodation, CloneDefocus, CloneShading, Eye, LensMaterial, Pupil, Spectacles,
};

/// Shows a "Spectacles" window editing the first camera with an [`Eye`].
/// Needs `bevy_egui`'s `EguiPlugin`.
pub struct SpectaclesPanelPlugin;

impl Plugin for SpectaclesPanelPlugin {
    fn build(&self, app: &mut App) {
        app.add_systems(EguiPrimaryContextPass, (panel_window, mirror_window));
    }
}

type EyeCamera<'a> = (
    Entity,
    &'a mut Eye,
    &'a mut CloneDefocus,
    Option<&'a mut Spectacles>,
    Option<&'a SpectaclesStatus>,
);

fn panel_window(
    mut commands: Commands,
    mut contexts: EguiContexts,
    mut eyes: Query<EyeCamera>,
) -> Result {
    let Some((entity, mut eye, mut defocus, spectacles, status)) = eyes.iter_mut().next() else {
        return Ok(());
    };
    let mut e = eye.clone();
    let mut d = defocus.clone();
    let mut s = spectacles.as_deref().cloned();
    egui::Window::new("Spectacles").show(contexts.ctx_mut()?, |ui| {
        spectacles_ui(ui, &mut e, &mut d, &mut s, status);
    });
    // Write back only what changed, so the plugin redoes only that.
    if *eye != e {
        *eye = e;
    }
    if *defocus != d {
        *defocus = d;
    }
    match (spectacles, s) {
        (Some(mut old), Some(new)) if *old != new => *old = new,
        (None, Some(new)) => {
            commands.entity(entity).insert(new);
        }
        (Some(_), None) => {
            commands.entity(entity).remove::<Spectacles>();
        }
        _ => {}
    }
    Ok(())
}

fn mirror_window(
    mut contexts: EguiContexts,
    mut mirrors: Query<(&mut CurvedMirror, Option<&MirrorState>)>,
) -> Result {
    let Some((mut mirror, state)) = mirrors.iter_mut().next() else {
        return Ok(());
    };
    let mut m = mirror.clone();
    egui::Window::new("Mirror").show(contexts.ctx_mut()?, |ui| mirror_ui(ui, &mut m, state));
    if *mirror != m {
        *mirror = m;
    }
    Ok(())
}

/// Draws a mirror's settings (how it reflects, its shape and grid) and
/// what the last trace gave.
pub fn mirror_ui(ui: &mut egui::Ui, mirror: &mut CurvedMirror, state: Option<&MirrorState>) {
    egui::Grid::new("optica_mirror")
        .num_columns(2)
        .show(ui, |ui| {
            ui.label("reflection");
            ui.horizontal(|ui| {
                ui.selectable_value(
                    &mut mirror.method,
                    MirrorMethod::PerVertex,
                    "per vertex (the paper's)",
                );
                ui.selectable_value(&mut mirror.method, MirrorMethod::CubeMap, "Bevy cube map");
            });
            ui.end_row();
            ui.label("radius (m, + convex)");
            ui.add(slider(&mut mirror.radius_m, -5.0..=5.0));
            ui.end_row();
            ui.label("grid cells across");
            let mut across = mirror.tessellation.x;
            ui.add(slider(&mut across, 2..=128));
            if across != mirror.tessellation.x {
                mirror.tessellation = UVec2::new(across, (across * 2).div_ceil(3).max(2));
            }
            ui.end_row();
            ui.label("image / face (px)");
            ui.add(slider(&mut mirror.resolution, 64..=2048));
            ui.end_row();
            ui.label("reflectance");
            ui.add(slider(&mut mirror.reflectance, 0.0..=1.0));
            ui.end_row();
        });
    if let Some(st) = state
        && matches!(mirror.method, MirrorMethod::PerVertex)
    {
        let v = st.viewpoint;
        ui.label(format!(
            "virtual viewpoint at ({:.2}, {:.2}, {:.2}) m, rays {:.1} mm from it (rms); {} vertices masked; \
             trace {:.2} ms",
            v.x,
            v.y,
            v.z,
            st.viewpoint_rms_m * 1e3,
            st.masked,
            st.trace_ms
        ));
    }
}

/// Draws the presets, every setting of `eye`, `defocus` and `spectacles`
/// (`None`: no glasses), and `status`.
pub fn spectacles_ui(
    ui: &mut egui::Ui,
    eye: &mut Eye,
    defocus: &mut CloneDefocus,
    spectacles: &mut Option<Spectacles>,
    status: Option<&SpectaclesStatus>,
) {
    ui.label("Presets:");
    ui.horizontal_wrapped(|ui| {
        for p in presets() {
            if ui.button(p.name).on_hover_text(p.description).clicked() {
                *eye = p.eye.clone();
                *spectacles = p.spectacles.clone();
            }
        }
    });
    ui.separator();
    eye_grid(ui, eye);
    ui.separator();
    let mut wears = spectacles.is_some();
    ui.checkbox(&mut wears, "glasses");
    if wears != spectacles.is_some() {
        // New glasses match the eye's prescription.
        *spectacles = wears.then(|| Spectacles {
            cylinder_d: eye.astigmatism.cylinder_d,
            axis_deg: eye.astigmatism.axis_deg,
            ..Spectacles::sphere(eye.refractive_error_d)
        });
    }
    if let Some(s) = spectacles {
        lens_grid(ui, s);
    }
    ui.separator();
    clones_grid(ui, defocus);
    if let Some(st) = status {
        status_lines(ui, st);
    }
}

/// The eye's sliders.
fn eye_grid(ui: &mut egui::Ui, eye: &mut Eye) {
    ui.heading("Eye");
    egui::Grid::new("spectacles_eye")
        .num_columns(2)
        .show(ui, |ui| {
            ui.label("refractive error (D)");
            ui.add(slider(&mut eye.refractive_error_d, -20.0..=20.0).step_by(0.25));
            ui.end_row();
            ui.label("astigmatism (D) / axis (°)");
            ui.horizontal(|ui| {
                let a = &mut eye.astigmatism;
                ui.add(slider(&mut a.cylinder_d, -6.0..=6.0).step_by(0.25));
                ui.add(slider(&mut a.axis_deg, 0.0..=180.0).step_by(5.0));
            });
            ui.end_row();
            ui.label("accommodation");
            ui.horizontal(|ui| match &mut eye.accommodation {
                Accommodation::Dioptres(d) => {
                    ui.add(slider(d, 0.0..=15.0).suffix(" D"));
                    if ui.button("by age").clicked() {
                        eye.accommodation = Accommodation::Age { years: 40.0 };
                    }
                }
                Accommodation::Age { years } => {
                    ui.add(slider(years, 5.0..=80.0).suffix(" years"));
                    if ui.button("in D").clicked() {
                        eye.accommodation =
                            Accommodation::Dioptres(eye.amplitude_d().unwrap_or(0.0) as f32);
                    }
                }
            });
            ui.end_row();
            ui.label("pupil");
            ui.horizontal(|ui| match &mut eye.pupil {
                Pupil::Diameter { mm } => {
                    ui.add(slider(mm, 0.0..=12.0).suffix(" mm"));
                    if ui.button("by light").clicked() {
                        eye.pupil = Pupil::Light {
                            luminance_cd_m2: 100.0,
                            age_years: 30.0,
                        };
                    }
                }
                Pupil::Light {
                    luminance_cd_m2,
                    age_years,
                } => {
                    ui.add(
                        slider(luminance_cd_m2, 0.01..=10_000.0)
                            .logarithmic(true)
                            .suffix(" cd/m²"),
                    );
                    ui.add(slider(age_years, 20.0..=83.0).suffix(" years"));
                    if ui.button("in mm").clicked() {
                        eye.pupil = Pupil::Diameter {
                            mm: eye.pupil_mm().unwrap_or(4.0) as f32,
                        };
                    }
                }
            });
            ui.end_row();
        });
}

/// The glasses' sliders.
fn lens_grid(ui: &mut egui::Ui, s: &mut Spectacles) {
    egui::Grid::new("spectacles_lens")
        .num_columns(2)
        .show(ui, |ui| {
            ui.label("sphere (D)");
            ui.add(slider(&mut s.sphere_d, -20.0..=20.0).step_by(0.25));
            ui.end_row();
            ui.label("cylinder (D) / axis (°)");
            ui.horizontal(|ui| {
                ui.add(slider(&mut s.cylinder_d, -6.0..=6.0).step_by(0.25));
                ui.add(slider(&mut s.axis_deg, 0.0..=180.0).step_by(5.0));
            });
            ui.end_row();
            ui.label("addition (D) / corridor (mm)");
            ui.horizontal(|ui| {
                ui.add(slider(&mut s.addition_d, 0.0..=3.5).step_by(0.25));
                ui.add(slider(&mut s.corridor_mm, 9.0..=20.0));
            });
            ui.end_row();
            ui.label("material");
            egui::ComboBox::from_id_salt("spectacles_material")
                .selected_text(s.material.name())
                .show_ui(ui, |ui| {
                    for m in LensMaterial::PRESETS {
                        ui.selectable_value(&mut s.material, m, m.name());
                    }
                });
            ui.end_row();
            ui.label("vertex distance (mm)");
            ui.add(slider(&mut s.vertex_distance_mm, 0.0..=25.0));
            ui.end_row();
            ui.label("blank diameter (mm)");
            ui.add(slider(&mut s.blank_diameter_mm, 20.0..=80.0));
            ui.end_row();
            ui.label("centre thickness (mm)");
            ui.add(slider(&mut s.min_centre_thickness_mm, 0.5..=6.0));
            ui.end_row();
            ui.label("decentration (mm)");
            ui.horizontal(|ui| {
                ui.add(slider(&mut s.decentration_mm.x, -10.0..=10.0));
                ui.add(slider(&mut s.decentration_mm.y, -10.0..=10.0));
            });
            ui.end_row();
            ui.label("refraction");
            ui.horizontal(|ui| {
                ui.checkbox(&mut s.refraction, "drawn");
                ui.checkbox(&mut s.chromatic_aberration, "chromatic aberration");
            });
            ui.end_row();
        });
}

/// The clones' settings.
fn clones_grid(ui: &mut egui::Ui, defocus: &mut CloneDefocus) {
    ui.heading("Clones");
    egui::Grid::new("spectacles_clones")
        .num_columns(2)
        .show(ui, |ui| {
            ui.label("clones S");
            ui.add(slider(&mut defocus.clones, 1..=64));
            ui.end_row();
            ui.label("shading");
            ui.horizontal(|ui| {
                ui.selectable_value(
                    &mut defocus.shading,
                    CloneShading::Reprojected,
                    "reprojected",
                );
                ui.selectable_value(
                    &mut defocus.shading,
                    CloneShading::Full,
                    "full (the paper's)",
                );
            });
            ui.end_row();
            ui.label("blur");
            ui.checkbox(&mut defocus.enabled, "on");
            ui.end_row();
            ui.label("voxels");
            ui.horizontal(|ui| {
                ui.selectable_value(
                    &mut defocus.field.eye_coordinates,
                    false,
                    "box (the paper's)",
                );
                ui.selectable_value(&mut defocus.field.eye_coordinates, true, "eye coordinates");
            });
            ui.end_row();
        });
}

/// What the plugin made of the settings.
fn status_lines(ui: &mut egui::Ui, st: &SpectaclesStatus) {
    ui.separator();
    let dist = |m: f32| {
        if m.is_infinite() {
            "∞".to_string()
        } else if m < 0.0 {
            format!("{:.2} m behind the eye", -m)
        } else {
            format!("{m:.2} m")
        }
    };
    ui.label(format!(
        "naked eye: sharp from {} to {}, pupil {:.1} mm",
        dist(st.near_point_m),
        dist(st.far_point_m),
        st.pupil_mm
    ));
    if let Some(c) = st.corrected_near_far_m {
        ui.label(format!("through the lens: {} to {}", dist(c.x), dist(c.y)));
    }
    if let Some(l) = st.lens_centre_edge_mm_front_d {
        ui.label(format!(
            "lens: centre {:.1} mm, edge {:.1} mm, base curve {:.2} D",
            l.x, l.y, l.z
        ));
    }
    if let Some(f) = st.field_aims_failed_crossed_filled {
        ui.label(format!(
            "field: {} bundles ({} blocked at the rim), {} voxels crossed, {} filled, {:.1} ms",
            f.x, f.y, f.z, f.w, st.precompute_ms
        ));
    }
    if let Some(e) = &st.error {
        ui.colored_label(egui::Color32::from_rgb(230, 120, 60), e.to_string());
    }
}

