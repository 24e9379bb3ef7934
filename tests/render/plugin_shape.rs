//! What every plugin does the same way: here, refusing loudly to be added
//! before Bevy's asset plugin (each embeds its shaders as assets), instead
//! of building without them and never drawing.

use bevy::prelude::*;

/// The panic message of adding `plugin` to a bare app.
fn refusal(plugin: impl Plugin + std::panic::UnwindSafe) -> String {
    let panic = std::panic::catch_unwind(move || {
        App::new().add_plugins(plugin);
    })
    .expect_err("a plugin without the asset plugin must panic");
    panic
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_default()
}

#[test]
fn every_plugin_added_before_the_asset_plugin_says_so() {
    let messages = [
        refusal(optica_compound_eye::CompoundEyePlugin),
        refusal(optica_dome::DomePlugin),
        refusal(optica_foveated_lod::FoveatedLodPlugin),
        refusal(optica_lens_flare::LensFlarePlugin),
        refusal(optica_spectacles::SpectaclesPlugin),
    ];
    for m in messages {
        assert!(m.contains("after Bevy's AssetPlugin"), "{m}");
    }
}

/// The crate panels draw every setting without changing any by
/// themselves: a frame of each, with no input, leaves the settings as they
/// were, also where they lie beyond a slider's range (a refused dome
/// camera, a flare with more rays and light than the sliders reach).
#[cfg(feature = "egui")]
#[test]
fn the_panels_draw_without_changing_the_settings() {
    use bevy_egui::egui;
    use optica_dome::{DomeCamera, DomeRefineStats};
    use optica_lens_flare::LensFlare;
    let ctx = egui::Context::default();
    let frame = |draw: &mut dyn FnMut(&mut egui::Ui)| {
        // (No painter here: the font atlas egui uploads is dropped.)
        let mut output = ctx.run_ui(egui::RawInput::default(), |ui| draw(ui));
        output.textures_delta.clear();
    };
    // A field of view past the maximum (refused) and a face size beyond the slider's
    // range: shown as they are, not clamped on sight.
    let refused = DomeCamera {
        fov_deg: 400.0,
        mode: optica_dome::DomeMode::CubeMap { face_px: 8192 },
        tolerance_px: 100.0,
        ..default()
    };
    assert!(refused.validate().is_err());
    let mut dome = refused;
    frame(&mut |ui| optica_dome::dome_ui(ui, &mut dome, None, &DomeRefineStats::default()));
    assert_eq!(dome, refused);

    let mut app = App::new();
    app.add_plugins((MinimalPlugins, AssetPlugin::default()));
    let assets = app.world().resource::<AssetServer>().clone();
    let mut flare = LensFlare {
        grid: 256,
        intensity: 5000.0,
        ..LensFlare::new(Handle::default())
    };
    let before = flare.clone();
    frame(&mut |ui| optica_lens_flare::lens_flare_ui(ui, &mut flare, None, &assets));
    assert_eq!(flare, before);
}
