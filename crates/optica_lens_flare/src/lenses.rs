//! The lens prescriptions optica ships, as embedded assets: load one with
//! `asset_server.load(lenses::TESSAR)`, no file to copy into your
//! `assets/` folder. [`LensFlarePlugin`](crate::LensFlarePlugin) embeds
//! them; each is a `.lens` file from an expired patent (the format of
//! `optica_optics::lens`), also compiled into
//! `optica_optics::lens::ALL_LENS_FILES`.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use optica_lens_flare::{LensFlare, LensFlarePlugin, lenses};
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, LensFlarePlugin))
//!     .add_systems(Startup, |mut commands: Commands, assets: Res<AssetServer>| {
//!         commands.spawn((Camera3d::default(), LensFlare::new(assets.load(lenses::TESSAR))));
//!     })
//!     .run();
//! ```

use std::path::{Path, PathBuf};

use bevy::asset::io::embedded::EmbeddedAssetRegistry;
use bevy::prelude::*;
use optica_optics::lens::ALL_LENS_FILES;

/// Brendel Tessar, US 2,854,889: f = 100 mm, f/2.8, 7 interfaces (21 ghosts).
pub const TESSAR: &str = "embedded://optica_lens_flare/lenses/tessar-us2854889.lens";
/// Angénieux double Gauss, US 2,701,982: f = 100 mm, f/1.1, 14 interfaces
/// (91 ghosts).
pub const DOUBLE_GAUSS: &str = "embedded://optica_lens_flare/lenses/double-gauss-us2701982.lens";
/// Tronnier Heliar, US 2,645,156: f = 100 mm, f/3.5, 8 interfaces (28 ghosts).
pub const HELIAR: &str = "embedded://optica_lens_flare/lenses/heliar-us2645156.lens";
/// Canon 70–200 mm zoom, US 5,537,259: 33 interfaces (528 ghosts), the
/// scale case.
pub const ZOOM: &str = "embedded://optica_lens_flare/lenses/zoom-canon-us5537259.lens";

/// Every shipped lens: (name for a menu, asset path).
pub const ALL: [(&str, &str); 4] = [
    ("Brendel Tessar f/2.8", TESSAR),
    ("Angénieux double Gauss f/1.1", DOUBLE_GAUSS),
    ("Heliar f/3.5", HELIAR),
    ("Canon 70–200 zoom (33 interfaces)", ZOOM),
];

/// Puts every shipped lens file into Bevy's embedded asset source.
pub(crate) fn embed(app: &mut App) {
    let Some(registry) = app.world().get_resource::<EmbeddedAssetRegistry>() else {
        warn!(
            "optica_lens_flare: no AssetPlugin before LensFlarePlugin: the shipped lenses are not embedded"
        );
        return;
    };
    let folder = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../optica_optics/lenses"
    ));
    for (name, text) in ALL_LENS_FILES {
        registry.insert_asset(
            folder.join(name),
            &Path::new("optica_lens_flare/lenses").join(name),
            text.as_bytes(),
        );
    }
}
