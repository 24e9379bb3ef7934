//! The five plugin scenes, as the showcase and the README's pictures show
//! them. Each plugin's own example uses its scene file alone.

pub mod common;
pub mod compound_eye;
pub mod dome;
pub mod foveated_lod;
pub mod lens_flare;
pub mod spectacles;

use bevy::prelude::*;

use common::SceneEntity;

/// One of the five scenes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Scene {
    /// Ghosts and a starburst through a real lens.
    LensFlare,
    /// An insect's compound eyes and their pseudopupil.
    CompoundEye,
    /// A planetarium's fisheye domemaster.
    Dome,
    /// Gaze-driven level of detail in the paper's CAVE.
    FoveatedLod,
    /// A room seen by a short-sighted eye.
    Spectacles,
}

impl Scene {
    /// Every scene, in the showcase's order.
    pub const ALL: [Scene; 5] = [
        Scene::LensFlare,
        Scene::CompoundEye,
        Scene::Dome,
        Scene::FoveatedLod,
        Scene::Spectacles,
    ];

    /// The name in file names and on the command line (the plugin's feature).
    pub fn name(self) -> &'static str {
        match self {
            Scene::LensFlare => lens_flare::NAME,
            Scene::CompoundEye => compound_eye::NAME,
            Scene::Dome => dome::NAME,
            Scene::FoveatedLod => foveated_lod::NAME,
            Scene::Spectacles => spectacles::NAME,
        }
    }

    /// What it shows, in a few words.
    pub fn title(self) -> &'static str {
        match self {
            Scene::LensFlare => "Lens flare — a low sun through a Tessar",
            Scene::CompoundEye => "Compound eye — the pseudopupil follows you",
            Scene::Dome => "Dome — a planetarium's fisheye",
            Scene::FoveatedLod => "Foveated LOD — the paper's CAVE",
            Scene::Spectacles => "Spectacles — a short-sighted eye",
        }
    }

    /// The picture's size for a width: each scene's own shape (three
    /// square walls side by side for the CAVE, a square domemaster).
    pub fn size(self, width: u32) -> (u32, u32) {
        let h = |num: u32, den: u32| (width * num / den).max(1);
        match self {
            Scene::LensFlare => (width, h(9, 16)),
            Scene::CompoundEye => (width, h(2, 3)),
            Scene::Dome => (width, width),
            Scene::FoveatedLod => (width - width % 3, h(1, 3)),
            Scene::Spectacles => (width, h(3, 4)),
        }
    }

    /// Frames a headless picture runs before it is read. The flare's
    /// occlusion is smoothed over frames (70 % of the last frame's each
    /// frame) from the frame its lens has loaded, which varies by a frame
    /// or two: 30 frames leave under 1e-4 of that in the picture. The
    /// others settle in a few.
    pub fn frames(self) -> u32 {
        match self {
            Scene::LensFlare => 30,
            Scene::CompoundEye => 2,
            Scene::Dome => 3,
            Scene::FoveatedLod => 4,
            Scene::Spectacles => 6,
        }
    }

    /// Adds the scene's plugin, its settings at the showcase's choices and
    /// its systems. The settings are those of the showcase's pictures.
    pub fn build(self, app: &mut App, width: u32) {
        let (w, h) = self.size(width);
        match self {
            Scene::LensFlare => {
                lens_flare::build(app);
                // Two seconds into the pan: the ghosts well spread.
                app.insert_resource(lens_flare::FlareScene {
                    lens: 0,
                    clock: 2.0,
                });
            }
            Scene::CompoundEye => {
                compound_eye::build(app);
                app.insert_resource(compound_eye::CompoundScene::default());
            }
            Scene::Dome => {
                dome::build(app);
                app.insert_resource(dome::DomeScene::default());
            }
            Scene::FoveatedLod => {
                foveated_lod::build(app);
                app.insert_resource(foveated_lod::Layout {
                    px: (w / 3).min(h),
                    ..default()
                });
            }
            Scene::Spectacles => {
                spectacles::build(app);
                app.insert_resource(spectacles::SpectaclesScene {
                    preset: optica::spectacles::presets::presets()
                        .into_iter()
                        .find(|p| p.name == "myope")
                        .expect("the myope preset"),
                    mirror: None,
                });
            }
        }
    }

    /// Spawns the scene (its settings must be in the world).
    pub fn spawn(self, world: &mut World) {
        let spawned = match self {
            Scene::LensFlare => world.run_system_cached(lens_flare::spawn),
            Scene::CompoundEye => world.run_system_cached(compound_eye::spawn),
            Scene::Dome => world.run_system_cached(dome::spawn),
            Scene::FoveatedLod => world.run_system_cached(foveated_lod::spawn),
            Scene::Spectacles => world.run_system_cached(spectacles::spawn),
        };
        if let Err(e) = spawned {
            error!("scene {}: {e}", self.name());
        }
    }

    /// A headless app's setup for this scene alone at `width`: the plugin,
    /// its settings and the scene spawned at start-up.
    pub fn setup_alone(self, app: &mut App, width: u32) {
        self.build(app, width);
        app.add_systems(Startup, move |world: &mut World| self.spawn(world));
    }
}

/// Which scene is shown, and which the panel or the keys asked for: the
/// showcase's [`switch_scene`] makes the second the first.
#[derive(Resource, Debug)]
pub struct Showcase {
    /// The scene on screen (none before the first frame).
    pub shown: Option<Scene>,
    /// The scene to show.
    pub wanted: Scene,
}

/// Takes the shown scene away and spawns the wanted one.
pub fn switch_scene(world: &mut World) {
    let Showcase { shown, wanted } = *world.resource::<Showcase>();
    if shown == Some(wanted) {
        return;
    }
    let old: Vec<Entity> = world
        .query_filtered::<Entity, With<SceneEntity>>()
        .iter(world)
        .collect();
    for entity in old {
        // A child goes with its parent: it may be gone already.
        if let Ok(e) = world.get_entity_mut(entity) {
            e.despawn();
        }
    }
    // What a scene sets for the whole app goes back to Bevy's defaults
    // (the next scene sets its own); a simulated head stops.
    world.insert_resource(ClearColor::default());
    world.insert_resource(GlobalAmbientLight::default());
    world.insert_resource(optica::foveated_lod::HeadSource::External);
    #[cfg(feature = "egui")]
    world.insert_resource(optica::compound_eye::CompoundEyePanel::default());
    wanted.spawn(world);
    world.flush();
    #[cfg(feature = "egui")]
    if wanted == Scene::CompoundEye {
        let _ = world.run_system_cached(compound_eye::edit_both_eyes);
    }
    world.resource_mut::<Showcase>().shown = Some(wanted);
    info!("showcase: {}", wanted.title());
}
