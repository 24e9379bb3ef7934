//! A settings panel for the flare (cargo feature `egui`).
//!
//! [`lens_flare_ui`] draws every setting of a [`LensFlare`] into an egui
//! `Ui` of yours, with what became of the ghosts; [`LensFlarePanelPlugin`]
//! shows it in a window for the (first) flare camera, with the flare's
//! share of the frame where the adapter has GPU timestamps (add Bevy's
//! `FrameTimeDiagnosticsPlugin` and `RenderDiagnosticsPlugin`).
//!
//! ```no_run
//! use bevy::prelude::*;
//! use bevy_egui::EguiPlugin;
//! use optica_lens_flare::{LensFlarePanelPlugin, LensFlarePlugin};
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, EguiPlugin::default(), LensFlarePlugin, LensFlarePanelPlugin))
//!     .run();
//! ```

use optica_plugin_kit::slider;

use bevy::diagnostic::{DiagnosticPath, DiagnosticsStore};
use bevy::prelude::*;
use bevy_egui::{EguiContexts, EguiPrimaryContextPass, egui};

use crate::{DEFAULT_COARSE_GHOST_PX, FlareGhosts, GhostResolution, LensFlare, lenses};

/// Shows a "Lens flare" window editing the first [`LensFlare`] camera.
/// Needs `bevy_egui`'s `EguiPlugin`.
pub struct LensFlarePanelPlugin;

impl Plugin for LensFlarePanelPlugin {
    fn build(&self, app: &mut App) {
        app.add_systems(EguiPrimaryContextPass, panel_window);
    }
}

fn panel_window(
    mut contexts: EguiContexts,
    mut cameras: Query<(&mut LensFlare, Option<&FlareGhosts>)>,
    assets: Res<AssetServer>,
    diagnostics: Option<Res<DiagnosticsStore>>,
) -> Result {
    let Some((mut flare, ghosts)) = cameras.iter_mut().next() else {
        return Ok(());
    };
    let mut edit = flare.clone();
    egui::Window::new("Lens flare").show(contexts.ctx_mut()?, |ui| {
        lens_flare_ui(ui, &mut edit, ghosts, &assets);
        if let Some(diagnostics) = &diagnostics {
            gpu_share(ui, diagnostics);
        }
    });
    if edit != *flare {
        *flare = edit;
    }
    Ok(())
}

/// Every setting of `flare` (the lens from the shipped [`lenses`]), its
/// refusal if any, and what became of the ghosts.
pub fn lens_flare_ui(
    ui: &mut egui::Ui,
    edit: &mut LensFlare,
    ghosts: Option<&FlareGhosts>,
    assets: &AssetServer,
) {
    let current = lenses::ALL
        .iter()
        .position(|(_, path)| {
            assets
                .get_path(edit.lens.id())
                .is_some_and(|p| p.path().ends_with(path))
        })
        .unwrap_or(0);
    egui::ComboBox::from_label("lens")
        .selected_text(lenses::ALL[current].0)
        .show_ui(ui, |ui| {
            for (name, path) in lenses::ALL {
                if ui
                    .selectable_label(lenses::ALL[current].1 == path, name)
                    .clicked()
                {
                    edit.lens = assets.load(path);
                }
            }
        });
    ui.add(
        slider(&mut edit.grid, 4..=128)
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
    ui.add(slider(&mut edit.wavelengths, 1..=8).text("wavelengths"));
    ui.add(
        slider(&mut edit.merge_wavelengths_px, 0.0..=4.0)
            .text("merge wavelengths below (px)"),
    );
    let mut coarse = edit.coarse_ghost_px.is_some();
    ui.checkbox(&mut coarse, "large ghosts at half that resolution");
    if coarse {
        let mut px = edit.coarse_ghost_px.unwrap_or(DEFAULT_COARSE_GHOST_PX);
        ui.add(
            slider(&mut px, 0.0..=256.0)
                .text("when wider than (px of the ghosts' target)"),
        );
        edit.coarse_ghost_px = Some(px);
        ui.add(
            slider(&mut edit.merge_cells, 0.0..=2.0)
                .text("merge their smooth cells (irradiance spread)"),
        );
    } else {
        edit.coarse_ghost_px = None;
    }
    ui.add(slider(&mut edit.aperture.blades, 0..=12).text("blades (0: round)"));
    ui.add(slider(&mut edit.aperture.roundness, 0.0..=1.0).text("blade roundness"));
    let mut stopped = edit.aperture.f_number.is_some();
    ui.checkbox(&mut stopped, "stopped down");
    if stopped {
        let mut f = edit.aperture.f_number.unwrap_or(8.0);
        ui.add(
            slider(&mut f, 1.0..=32.0)
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
        slider(&mut edit.ghost_budget, 1..=528)
            .logarithmic(true)
            .text("ghost budget"),
    );
    ui.add(
        slider(&mut edit.intensity, 0.1..=1000.0)
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
        ui.add(slider(&mut b.size, 0.02..=1.0).text("starburst size"));
        ui.add(
            slider(&mut b.intensity, 1e-5..=0.1)
                .logarithmic(true)
                .text("starburst share"),
        );
        ui.add(slider(&mut b.specks, 0..=400).text("dust specks"));
        ui.add(slider(&mut b.scratches, 0..=40).text("scratches"));
    }
    let mut ringing = edit.ringing.is_some();
    ui.checkbox(&mut ringing, "ringing");
    edit.ringing = ringing.then(|| edit.ringing.unwrap_or_default());
    if let Some(r) = edit.ringing.as_mut() {
        ui.add(
            slider(&mut r.fresnel_number, 1.0..=1000.0)
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
}

/// The flare's passes on the GPU (where the adapter has timestamp
/// queries) against the whole frame.
fn gpu_share(ui: &mut egui::Ui, diagnostics: &DiagnosticsStore) {
    let smoothed = |path: &'static str| {
        diagnostics
            .get(&DiagnosticPath::const_new(path))
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
}

