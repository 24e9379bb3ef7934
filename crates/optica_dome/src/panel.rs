//! A settings panel for the dome camera (cargo feature `egui`).
//!
//! [`dome_ui`] draws a [`DomeCamera`]'s mode, lens, field of view, tilt and
//! tolerance into an egui `Ui` of yours, with its refusal and the
//! refinement's work; [`DomePanelPlugin`] shows it in a window for the
//! (first) dome camera.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use bevy_egui::EguiPlugin;
//! use optica_dome::{DomePanelPlugin, DomePlugin};
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, EguiPlugin::default(), DomePlugin, DomePanelPlugin))
//!     .run();
//! ```

use optica_plugin_kit::slider;

use bevy::prelude::*;
use bevy_egui::{EguiContexts, EguiPrimaryContextPass, egui};

use crate::{DomeCamera, DomeLens, DomeMode, DomeRefineStats, DomeStatus};

/// Shows a "Dome" window editing the first [`DomeCamera`]. Needs
/// `bevy_egui`'s `EguiPlugin`.
pub struct DomePanelPlugin;

impl Plugin for DomePanelPlugin {
    fn build(&self, app: &mut App) {
        app.add_systems(EguiPrimaryContextPass, panel_window);
    }
}

fn panel_window(
    mut contexts: EguiContexts,
    mut cameras: Query<(&mut DomeCamera, Option<&DomeStatus>)>,
    stats: Res<DomeRefineStats>,
) -> Result {
    let Some((mut dome, status)) = cameras.iter_mut().next() else {
        return Ok(());
    };
    let mut edit = *dome;
    egui::Window::new("Dome").show(contexts.ctx_mut()?, |ui| {
        dome_ui(ui, &mut edit, status, &stats);
    });
    if edit != *dome {
        *dome = edit;
    }
    Ok(())
}

/// A dome camera's settings, why they are refused (or the vertex
/// projection's patch failed, from `status`), and the refinement's last
/// pass.
pub fn dome_ui(
    ui: &mut egui::Ui,
    edit: &mut DomeCamera,
    status: Option<&DomeStatus>,
    stats: &DomeRefineStats,
) {
    let mut cube = matches!(edit.mode, DomeMode::CubeMap { .. });
    ui.horizontal(|ui| {
        ui.radio_value(&mut cube, false, "vertex projection");
        ui.radio_value(&mut cube, true, "cube map");
    });
    edit.mode = match (cube, edit.mode) {
        (false, _) => DomeMode::Vertex,
        (true, DomeMode::CubeMap { face_px }) => {
            let mut face_px = face_px;
            ui.add(
                slider(&mut face_px, 64..=4096)
                    .logarithmic(true)
                    .text("face size (px)"),
            );
            DomeMode::CubeMap { face_px }
        }
        (true, DomeMode::Vertex) => DomeMode::CubeMap { face_px: 768 },
    };
    egui::ComboBox::from_label("projection")
        .selected_text(edit.lens.name())
        .show_ui(ui, |ui| {
            for lens in DomeLens::ALL {
                let chosen = std::mem::discriminant(&edit.lens) == std::mem::discriminant(&lens);
                if ui.selectable_label(chosen, lens.name()).clicked() && !chosen {
                    edit.lens = lens;
                }
            }
        });
    if let DomeLens::Polynomial { k } = &mut edit.lens {
        ui.horizontal(|ui| {
            for (i, c) in k.iter_mut().enumerate() {
                ui.label(format!("k{}", i + 1));
                ui.add(egui::DragValue::new(c).speed(0.001).max_decimals(5));
            }
        });
    }
    // The panorama sees the whole sphere: no field of view to set.
    if edit.lens != DomeLens::Equirectangular {
        ui.add(slider(&mut edit.fov_deg, 60.0..=350.0).text("field of view (°)"));
    }
    ui.add(slider(&mut edit.tilt_deg, -30.0..=90.0).text("tilt (°)"));
    ui.add(
        slider(&mut edit.tolerance_px, 0.1..=40.0)
            .logarithmic(true)
            .text("tolerance (px)"),
    );
    if edit.mode == DomeMode::Vertex {
        ui.checkbox(&mut edit.exact_attributes, "exact texture inside triangles");
    }
    if let Err(e) = edit.validate() {
        ui.colored_label(egui::Color32::from_rgb(230, 120, 60), e.to_string());
    }
    if edit.mode == DomeMode::Vertex {
        ui.label(format!(
            "refinement: {} meshes split again ({} vertices), {} kept, {:.1} ms",
            stats.rebuilt, stats.vertices, stats.kept, stats.cpu_ms
        ));
    }
    if let Some(e) = status.and_then(|s| s.error.as_ref()).filter(|e| {
        matches!(
            e,
            crate::Error::ShaderPatch(_) | crate::Error::AttributePatch(_)
        )
    }) {
        ui.colored_label(egui::Color32::from_rgb(230, 120, 60), e.to_string());
    }
}
