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
