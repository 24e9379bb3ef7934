//! Lens prescriptions as Bevy assets: `.lens` files (the format of
//! `optica_optics::lens`), loaded by [`LensLoader`] and hot-reloaded with
//! Bevy's `file_watcher` feature.

use bevy::asset::io::Reader;
use bevy::asset::{AssetLoader, LoadContext};
use bevy::prelude::*;
use optica_optics::lens::{LensPrescription, ParseError};

/// A lens prescription loaded from a `.lens` file.
///
/// ```no_run
/// use bevy::prelude::*;
/// use optica_lens_flare::LensAsset;
///
/// fn load(assets: Res<AssetServer>) {
///     let tessar: Handle<LensAsset> = assets.load("lenses/tessar-us2854889.lens");
/// }
/// ```
#[derive(Asset, TypePath, Clone, Debug)]
pub struct LensAsset(pub LensPrescription);

/// Loads `.lens` files into [`LensAsset`]s. A file that does not parse is
/// refused with an error naming its line and field (Bevy logs it); an asset
/// already loaded from that path keeps its last good version.
#[derive(Default, TypePath)]
pub struct LensLoader;

/// Why a `.lens` file could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LensLoadError {
    /// The file could not be read.
    #[error("could not read the lens file: {0}")]
    Io(#[from] std::io::Error),
    /// The file is not a valid prescription.
    #[error(transparent)]
    Parse(#[from] ParseError),
}

impl AssetLoader for LensLoader {
    type Asset = LensAsset;
    type Settings = ();
    type Error = LensLoadError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        _settings: &(),
        _context: &mut LoadContext<'_>,
    ) -> Result<LensAsset, LensLoadError> {
        let mut bytes = Vec::new();
        reader.read_to_end(&mut bytes).await?;
        Ok(LensAsset(LensPrescription::parse_bytes(&bytes)?))
    }

    fn extensions(&self) -> &[&str] {
        &["lens"]
    }
}
