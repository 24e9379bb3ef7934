//! A panel for the foveation (cargo feature `egui`): the settings, the
//! simulated gaze, each object's level and triangles, and the visual field
//! drawn with the objects in it.
//!
//! [`foveation_ui`] draws the settings into an egui `Ui` of yours;
//! [`FoveatedLodPanelPlugin`] shows everything in a window.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use bevy_egui::EguiPlugin;
//! use optica_foveated_lod::{FoveatedLodPanelPlugin, FoveatedLodPlugin};
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, EguiPlugin::default(), FoveatedLodPlugin, FoveatedLodPanelPlugin))
//!     .run();
//! ```

use optica_plugin_kit::slider;

use bevy::prelude::*;
use bevy_egui::{EguiContexts, EguiPrimaryContextPass, egui};
use optica_optics::foveated_lod::FieldAngles;

use crate::{
    CaveView, Eye, FieldBoundary, FieldEyes, Foveation, FoveationGate, FoveationWork, GazeLod,
    GazeLodState, GazeRayTracer, GazeRayTracerState, GazeState, HeadSource, MAX_REFLECT, RayTraced,
};

/// Shows a "Foveated LOD" window: [`foveation_ui`], the simulated gaze (when
/// [`HeadSource::Simulated`]), the field diagram and the objects' levels.
/// Shown while a [`GazeLod`], [`CaveView`] or [`GazeRayTracer`] exists.
/// Needs `bevy_egui`'s `EguiPlugin`.
pub struct FoveatedLodPanelPlugin;

impl Plugin for FoveatedLodPanelPlugin {
    fn build(&self, app: &mut App) {
        // Shown only while something uses the gaze, as the plugin's own
        // systems run.
        app.add_systems(
            EguiPrimaryContextPass,
            panel_window.run_if(
                any_with_component::<GazeLod>
                    .or_else(any_with_component::<CaveView>)
                    .or_else(any_with_component::<GazeRayTracer>),
            ),
        );
    }
}

/// Draws every setting of [`Foveation`]; true when one changed.
pub fn foveation_ui(ui: &mut egui::Ui, f: &mut Foveation) -> bool {
    let mut changed = ui.checkbox(&mut f.enabled, "foveation on").changed();
    let deg =
        |ui: &mut egui::Ui, v: &mut f32, range: std::ops::RangeInclusive<f32>, label: &str| {
            ui.add(slider(v, range).suffix("°").text(label))
                .changed()
        };
    changed |= deg(ui, &mut f.central_deg, 1.0..=90.0, "central field");
    let c = f.central_deg;
    changed |= deg(ui, &mut f.ear_deg, c..=180.0, "ear side");
    changed |= deg(ui, &mut f.nose_deg, c..=180.0, "nose side");
    changed |= deg(ui, &mut f.upper_deg, c..=180.0, "up");
    changed |= deg(ui, &mut f.lower_deg, c..=180.0, "down");
    ui.horizontal(|ui| {
        changed |= ui
            .radio_value(&mut f.eyes, FieldEyes::Cyclopean, "one eye (paper)")
            .changed();
        changed |= ui
            .radio_value(&mut f.eyes, FieldEyes::PerEye, "per eye")
            .changed();
    });
    ui.horizontal(|ui| {
        changed |= ui
            .radio_value(&mut f.boundary, FieldBoundary::PaperEq7, "eq. 7")
            .changed();
        changed |= ui
            .radio_value(&mut f.boundary, FieldBoundary::TrueEllipse, "ellipse")
            .changed();
    });
    changed |= ui
        .add(slider(&mut f.steps, 1..=32).text("level steps"))
        .changed();
    let max_band = (1.0 / f.steps as f32) * 0.99;
    f.dead_band = f.dead_band.min(max_band);
    changed |= ui
        .add(slider(&mut f.dead_band, 0.0..=max_band).text("dead band"))
        .changed();
    changed |= ui
        .add(
            slider(&mut f.min_dwell_s, 0.0..=2.0)
                .suffix(" s")
                .text("dwell"),
        )
        .changed();
    changed |= ui
        .add(slider(&mut f.min_saving, 0.0..=1.0).text("foveate when saving ≥"))
        .changed();
    changed |= ui
        .add(
            slider(&mut f.hold_timeout_s, 0.0..=2.0)
                .suffix(" s")
                .text("dropout hold"),
        )
        .changed();
    changed
}

#[allow(clippy::too_many_arguments)]
fn panel_window(
    mut contexts: EguiContexts,
    mut foveation: ResMut<Foveation>,
    mut source: ResMut<HeadSource>,
    gaze: Res<GazeState>,
    work: Res<FoveationWork>,
    gate: Res<FoveationGate>,
    objects: Query<(Entity, Option<&Name>, &GazeLodState, &GlobalTransform)>,
    traced: Query<(), With<RayTraced>>,
    mut tracers: Query<(
        Entity,
        Option<&Name>,
        &mut GazeRayTracer,
        &GazeRayTracerState,
    )>,
) -> Result {
    egui::Window::new("Foveated LOD").show(contexts.ctx_mut()?, |ui| {
        let mut f = foveation.clone();
        if foveation_ui(ui, &mut f) {
            *foveation = f;
        }
        if let HeadSource::Simulated(sim) = source.as_mut() {
            ui.separator();
            ui.label("simulated gaze (arrow keys)");
            ui.add(
                slider(&mut sim.gaze_yaw_deg, -90.0..=90.0)
                    .suffix("°")
                    .text("yaw"),
            );
            ui.add(
                slider(&mut sim.gaze_pitch_deg, -80.0..=80.0)
                    .suffix("°")
                    .text("pitch"),
            );
            ui.checkbox(&mut sim.dropped, "tracker dropout");
        }
        ui.separator();
        let status = if gaze.full_quality() {
            "no gaze: full quality"
        } else {
            "gaze tracked"
        };
        ui.label(status);
        ui.label(format!(
            "levels would save {:.0} % of the triangles: {}",
            100.0 * gate.saving,
            if gate.active {
                "foveating"
            } else {
                "full meshes (too little to gain)"
            }
        ));
        for (e, name, mut tracer, state) in &mut tracers {
            ui.separator();
            ui.label(format!(
                "ray tracer {}: {} (saves ~{:.0} % of the primary rays; {:.0} % central, {:.0} % outside)",
                name.map_or_else(|| e.to_string(), |n| n.to_string()),
                if state.foveating { "foveating" } else { "full quality" },
                100.0 * state.saving,
                100.0 * state.central,
                100.0 * state.outside,
            ));
            ui.horizontal(|ui| {
                ui.checkbox(&mut tracer.foveate, "foveate");
                ui.add(slider(&mut tracer.periphery_scale, 1..=8).text("periphery scale"));
                ui.add(slider(&mut tracer.reflect_max, 0..=MAX_REFLECT).text("Reflect_max"));
            });
        }
        field_diagram(ui, &foveation, &gaze, &objects);
        ui.separator();
        egui::Grid::new("objects").striped(true).show(ui, |ui| {
            ui.label("object");
            ui.label("level");
            ui.label("step");
            ui.label("triangles");
            ui.end_row();
            for (e, name, s, _) in &objects {
                ui.label(name.map_or_else(|| e.to_string(), |n| n.to_string()));
                if traced.contains(e) {
                    ui.label("per ray");
                    ui.label("-");
                    ui.label(format!("traced, {} LODs", s.chain.as_ref().map_or(0, |c| c.meshes.len())));
                    ui.end_row();
                    continue;
                }
                ui.label(format!("{:.2}", s.level));
                ui.label(if s.hidden {
                    format!("{} (hidden)", s.step)
                } else {
                    s.step.to_string()
                });
                ui.label(s.triangles.to_string());
                ui.end_row();
            }
        });
        ui.label(format!(
            "work: {} gaze updates, {} levels, {} mesh swaps, {} chains",
            work.gaze_updates, work.levels_computed, work.mesh_swaps, work.chains_built
        ));
    });
    Ok(())
}

/// The (m_α, m_β) plane of the paper's fig. 3: the central circle, the
/// peripheral boundary, and each object's centre coloured by its level.
fn field_diagram(
    ui: &mut egui::Ui,
    foveation: &Foveation,
    gaze: &GazeState,
    objects: &Query<(Entity, Option<&Name>, &GazeLodState, &GlobalTransform)>,
) {
    let Ok(checked) = foveation.check() else {
        ui.label("invalid settings: defaults in use");
        return;
    };
    let field = checked.field(Eye::Cyclopean);
    let (response, painter) = ui.allocate_painter(egui::vec2(240.0, 160.0), egui::Sense::hover());
    let rect = response.rect;
    // ±180° by ±90°, one point per 1.5°.
    let scale = rect.width() / 360.0;
    let to_screen = |a_deg: f64, b_deg: f64| {
        egui::pos2(
            rect.center().x + a_deg as f32 * scale,
            rect.center().y - b_deg as f32 * scale,
        )
    };
    painter.rect_stroke(
        rect,
        0.0,
        egui::Stroke::new(1.0, egui::Color32::GRAY),
        egui::StrokeKind::Inside,
    );
    let curve = |radius: &dyn Fn(f64) -> f64| -> Vec<egui::Pos2> {
        (0..=240)
            .map(|i| {
                let phi = i as f64 / 240.0 * std::f64::consts::TAU;
                let r = radius(phi).min(std::f64::consts::PI).to_degrees();
                to_screen(r * phi.cos(), r * phi.sin())
            })
            .collect()
    };
    let central = field.extents().central;
    painter.add(egui::Shape::line(
        curve(&|_| central),
        egui::Stroke::new(1.5, egui::Color32::LIGHT_GREEN),
    ));
    painter.add(egui::Shape::line(
        curve(&|phi| {
            field.boundary(FieldAngles {
                m_alpha: phi.cos(),
                m_beta: phi.sin(),
            })
        }),
        egui::Stroke::new(1.5, egui::Color32::YELLOW),
    ));
    let Some(frame) = gaze.frame(Eye::Cyclopean) else {
        return;
    };
    for (_, _, state, transform) in objects {
        let local = frame.to_local(transform.translation().as_dvec3() - frame.eye());
        let a = field.angles(local);
        let level = state.level.clamp(0.0, 1.0);
        let colour =
            egui::Color32::from_rgb((255.0 * (1.0 - level)) as u8, (255.0 * level) as u8, 80);
        painter.circle_filled(
            to_screen(a.m_alpha.to_degrees(), a.m_beta.to_degrees()),
            3.5,
            colour,
        );
    }
}

