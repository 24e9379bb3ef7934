//! A settings panel for the material (cargo feature `egui`).
//!
//! [`compound_eye_ui`] draws every setting of a [`CompoundEye`] into an egui
//! `Ui` of yours; [`CompoundEyePanelPlugin`] shows it in a window for the
//! material named by the [`CompoundEyePanel`] resource.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use bevy_egui::EguiPlugin;
//! use optica_compound_eye::{CompoundEyeMaterial, CompoundEyePanel, CompoundEyePanelPlugin, CompoundEyePlugin};
//!
//! fn pick(mut commands: Commands, materials: Res<Assets<CompoundEyeMaterial>>) {
//!     if let Some((id, _)) = materials.iter().next() {
//!         commands.insert_resource(CompoundEyePanel { materials: vec![id] });
//!     }
//! }
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, EguiPlugin::default(), CompoundEyePlugin, CompoundEyePanelPlugin))
//!     .add_systems(PostStartup, pick)
//!     .run();
//! ```

use optica_plugin_kit::slider;

use bevy::prelude::*;
use bevy_egui::{EguiContexts, EguiPrimaryContextPass, egui};

use crate::presets::PRESETS;
use crate::{CompoundEye, CompoundEyeMaterial, EyeLattice, EyeOutput};

/// Which materials the panel edits: every one listed gets the same settings.
#[derive(Resource, Default, Clone, Debug)]
pub struct CompoundEyePanel {
    /// The materials to edit (e.g. the two eyes of a head).
    pub materials: Vec<AssetId<CompoundEyeMaterial>>,
}

/// Shows a "Compound eye" window editing the materials of [`CompoundEyePanel`].
/// Needs `bevy_egui`'s `EguiPlugin`.
pub struct CompoundEyePanelPlugin;

impl Plugin for CompoundEyePanelPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<CompoundEyePanel>()
            .add_systems(EguiPrimaryContextPass, panel_window);
    }
}

fn panel_window(
    mut contexts: EguiContexts,
    panel: Res<CompoundEyePanel>,
    mut materials: ResMut<Assets<CompoundEyeMaterial>>,
) -> Result {
    let Some(first) = panel.materials.first().and_then(|id| materials.get(*id)) else {
        return Ok(());
    };
    let mut eye = first.extension.clone();
    let mut changed = false;
    egui::Window::new("Compound eye").show(contexts.ctx_mut()?, |ui| {
        changed = compound_eye_ui(ui, &mut eye)
    });
    if changed {
        for id in &panel.materials {
            if let Some(mut m) = materials.get_mut(*id) {
                m.extension = eye.clone();
            }
        }
    }
    Ok(())
}

/// Draws every setting of `eye` and the species presets; returns whether
/// anything changed. Invalid combinations are shown, not prevented: the
/// material then renders as its base (see [`CompoundEye::validate`]), and the
/// panel says why.
pub fn compound_eye_ui(ui: &mut egui::Ui, eye: &mut CompoundEye) -> bool {
    let before = eye.clone();
    ui.horizontal_wrapped(|ui| {
        ui.label("Preset:");
        for preset in PRESETS {
            let short = preset.name.split(" (").next().unwrap_or(preset.name);
            if ui
                .button(short)
                .on_hover_text(format!("{} ommatidia; {}", preset.ommatidia, preset.source))
                .clicked()
            {
                let keep = (eye.pigment_texture.clone(), eye.output);
                *eye = CompoundEye::from_preset(&preset);
                (eye.pigment_texture, eye.output) = keep;
            }
        }
        if ui
            .button("thesis")
            .on_hover_text("Sagawa's model: square lattice, d = 2r, one lens")
            .clicked()
        {
            *eye = CompoundEye {
                output: eye.output,
                pigment_texture: eye.pigment_texture.take(),
                ..CompoundEye::thesis(eye.facets_per_uv, 1.5, eye.slices)
            };
        }
    });
    ui.separator();
    egui::Grid::new("compound_eye_settings")
        .num_columns(2)
        .show(ui, |ui| {
            ui.label("facets per UV unit (R_t)");
            ui.add(slider(&mut eye.facets_per_uv, 1.0..=400.0).logarithmic(true));
            ui.end_row();
            ui.label("lattice");
            ui.horizontal(|ui| {
                ui.selectable_value(&mut eye.lattice, EyeLattice::Square, "square");
                ui.selectable_value(&mut eye.lattice, EyeLattice::Hexagonal, "hexagonal");
            });
            ui.end_row();
            ui.label("lens radius (of the cell)");
            ui.add(slider(&mut eye.lens_radius, 0.05..=1.0));
            ui.end_row();
            ui.label("lens index");
            ui.add(slider(&mut eye.lens_index, 0.5..=2.5));
            ui.end_row();
            ui.label("pigment depth (lens radii)");
            ui.add(slider(&mut eye.pigment_depth, 2.0..=6.0));
            ui.end_row();
            ui.label("lattice axes");
            ui.checkbox(&mut eye.tangent_axes, "along the mesh's tangents");
            ui.end_row();
            ui.label("");
            ui.checkbox(&mut eye.axis_field, "along the mesh's axis field");
            ui.end_row();
            ui.label("lens search");
            ui.checkbox(&mut eye.exact, "exact (walk the lattice)");
            ui.end_row();
            ui.label("slice planes K");
            ui.add_enabled(!eye.exact, slider(&mut eye.slices, 0..=64));
            ui.end_row();
            ui.label("neighbouring lenses");
            ui.checkbox(&mut eye.follow_neighbours, "follow the ray on");
            ui.end_row();
            ui.label("Fresnel");
            ui.checkbox(&mut eye.fresnel, "lens surfaces reflect");
            ui.end_row();
            ui.label("prefilter");
            ui.checkbox(&mut eye.prefilter, "average sub-pixel facets");
            ui.end_row();
            ui.label("pigment radius (facets)");
            ui.add(slider(&mut eye.pigment.radius, 0.0..=0.6));
            ui.end_row();
            ui.label("pigment edge (facets)");
            ui.add(slider(&mut eye.pigment.softness, 0.0..=0.3));
            ui.end_row();
            ui.label("pigment darkness");
            ui.add(slider(&mut eye.pigment.darkness, 0.0..=1.0));
            ui.end_row();
            ui.label("pigment texture scale");
            ui.horizontal(|ui| {
                ui.add(egui::DragValue::new(&mut eye.pigment_uv_scale.x).speed(0.01));
                ui.add(egui::DragValue::new(&mut eye.pigment_uv_scale.y).speed(0.01));
            });
            ui.end_row();
            ui.label("pigment texture offset");
            ui.horizontal(|ui| {
                ui.add(egui::DragValue::new(&mut eye.pigment_uv_offset.x).speed(0.01));
                ui.add(egui::DragValue::new(&mut eye.pigment_uv_offset.y).speed(0.01));
            });
            ui.end_row();
            ui.label("output");
            ui.horizontal(|ui| {
                ui.selectable_value(&mut eye.output, EyeOutput::Shaded, "shaded");
                ui.selectable_value(&mut eye.output, EyeOutput::PigmentOnly, "optics only");
            });
            ui.end_row();
        });
    if let Err(e) = eye.validate() {
        ui.colored_label(
            egui::Color32::from_rgb(230, 120, 60),
            format!("lattice off: {e}"),
        );
    }
    *eye != before
}

