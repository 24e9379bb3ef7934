//! The shipped lenses load from the plugin's embedded source, every one of
//! them, and a path names each shipped file.

use std::sync::{Arc, Mutex};

use bevy::prelude::*;
use optica_harness::{Adapter, Headless};
use optica_lens_flare::{LensAsset, LensFlarePlugin, lenses};
use optica_optics::lens::ALL_LENS_FILES;

#[test]
fn every_shipped_lens_loads_from_its_embedded_path() {
    assert_eq!(lenses::ALL.len(), ALL_LENS_FILES.len());
    for (name, _) in ALL_LENS_FILES {
        assert!(
            lenses::ALL
                .iter()
                .any(|(_, path)| path.ends_with(&format!("/lenses/{name}"))),
            "{name} has no path"
        );
    }
    let loaded = Arc::new(Mutex::new(Vec::<(String, usize)>::new()));
    let seen = loaded.clone();
    Headless::new(16, 16)
        .adapter(Adapter::Noop)
        .frames(30)
        .check_pipelines(move |app: &mut App| {
            app.add_plugins(LensFlarePlugin)
                .add_systems(
                    Startup,
                    |mut commands: Commands, assets: Res<AssetServer>| {
                        let handles: Vec<Handle<LensAsset>> = lenses::ALL
                            .iter()
                            .map(|(_, path)| assets.load(*path))
                            .collect();
                        commands.insert_resource(Held(handles));
                    },
                )
                .add_systems(
                    Last,
                    move |held: Res<Held>, lenses: Res<Assets<LensAsset>>| {
                        let mut seen = seen.lock().unwrap();
                        seen.clear();
                        for (h, (name, _)) in held.0.iter().zip(lenses::ALL) {
                            if let Some(lens) = lenses.get(h) {
                                seen.push((name.to_string(), lens.0.surfaces().len()));
                            }
                        }
                    },
                );
        })
        .expect("the app runs");
    let loaded = loaded.lock().unwrap().clone();
    eprintln!("{loaded:?}");
    assert_eq!(loaded.len(), lenses::ALL.len(), "loaded: {loaded:?}");
    // The zoom has 33 interfaces (and the stop).
    assert!(
        loaded.iter().any(|(n, s)| n.contains("zoom") && *s >= 33),
        "{loaded:?}"
    );
}

/// The lens handles, kept so the assets stay loaded.
#[derive(Resource)]
struct Held(Vec<Handle<LensAsset>>);
