//! The showcase's scenes (`examples/scenes/`): each drawn alone matches the
//! README's picture of it (`docs/images/<scene>.png`, the goldens), builds
//! its own plugin's pipelines and no other plugin's, and switching from
//! scene to scene in one app leaves nothing of the scene before: the same
//! entities as the scene alone, no other plugin's pipeline built after
//! the switch, and the same picture.

#[path = "../../examples/scenes/mod.rs"]
mod scenes;

use std::collections::{BTreeMap, BTreeSet};
use std::sync::{Arc, Mutex};

use bevy::prelude::*;
use bevy::render::RenderApp;
use bevy::render::render_resource::PipelineCache;
use optica_harness::{Adapter, Golden, Headless, Tolerance};
use scenes::common::SceneEntity;
use scenes::{Scene, Showcase, switch_scene};

/// The README pictures' width.
const WIDTH: u32 = 480;

fn headless(scene: Scene) -> Headless {
    let (w, h) = scene.size(WIDTH);
    Headless::new(w, h).frames(scene.frames())
}

/// Every scene's plugin built, as in the showcase; `spawned` spawned.
fn showcase_app(app: &mut App, spawned: Scene) {
    for scene in Scene::ALL {
        scene.build(app, WIDTH);
    }
    app.insert_resource(Showcase {
        shown: None,
        wanted: spawned,
    })
    .add_systems(PreUpdate, switch_scene);
}

/// The plugin a pipeline's label belongs to, if any of ours.
fn plugin_of(label: &str) -> Option<Scene> {
    Scene::ALL.into_iter().find(|s| label.contains(s.name()))
}

/// The README's pictures are what the scenes draw today.
#[test]
fn readme_pictures_are_what_the_scenes_draw() {
    let goldens = Golden::new(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/images"));
    for scene in Scene::ALL {
        let frame = headless(scene)
            .render(|app| scene.setup_alone(app, WIDTH))
            .expect("render");
        goldens.assert_matches(scene.name(), &frame, Tolerance::default());
    }
}

/// With all five plugins in the app and one scene spawned, only that
/// scene's plugin builds pipelines of its own (those whose label names an
/// optica plugin).
#[test]
fn a_scene_builds_only_its_plugins_pipelines() {
    for scene in Scene::ALL {
        let report = Headless::new(64, 64)
            .adapter(Adapter::Noop)
            .frames(scene.frames())
            .check_pipelines(|app| showcase_app(app, scene))
            .expect("pipelines compile");
        let ours: BTreeSet<_> = report
            .labels
            .iter()
            .filter_map(|l| plugin_of(l).map(|p| (p, l.clone())))
            .collect();
        eprintln!("{}: {} pipelines, ours {ours:?}", scene.name(), report.ok);
        for (plugin, label) in &ours {
            assert_eq!(*plugin, scene, "{} built {label}", scene.name());
        }
    }
}

/// What one update of the switching app saw.
#[derive(Clone, Debug, Default)]
struct Census {
    /// Entities with a `SceneEntity` marker.
    scene_entities: usize,
    /// Meshes drawn (a dome twin or a spectacles clone counts), cameras
    /// and lights.
    drawn: (usize, usize, usize),
}

/// Runs `order` in one app, a scene every `frames` updates, and returns the
/// census at the last update of each scene and the final picture.
fn switch_through(
    order: Vec<Scene>,
    frames: u32,
) -> (
    Vec<Census>,
    BTreeMap<String, Option<Scene>>,
    image::RgbaImage,
) {
    let seen = Arc::new(Mutex::new(Vec::<Census>::new()));
    let labels = PipelineLabels::default();
    let pipelines = labels.0.clone();
    let log = seen.clone();
    let last = *order.last().unwrap();
    let total = frames * order.len() as u32;
    let frame = headless(last)
        .frames(total)
        .render(move |app: &mut App| {
            showcase_app(app, order[0]);
            let mut update = 0u32;
            app.add_systems(Last, move |world: &mut World| {
                update += 1;
                if !update.is_multiple_of(frames) {
                    return;
                }
                let scene_entities = world
                    .query_filtered::<(), With<SceneEntity>>()
                    .iter(world)
                    .count();
                let drawn = (
                    world.query::<&Mesh3d>().iter(world).count(),
                    world.query::<&Camera>().iter(world).count(),
                    world
                        .query_filtered::<(), Or<(With<PointLight>, With<DirectionalLight>)>>()
                        .iter(world)
                        .count(),
                );
                log.lock().unwrap().push(Census {
                    scene_entities,
                    drawn,
                });
                let next = (update / frames) as usize;
                if let Some(&scene) = order.get(next) {
                    world.resource_mut::<Showcase>().wanted = scene;
                }
            });
            // The render world's pipeline cache, read at the end of each
            // frame, each of our pipelines with the scene shown in the
            // frame it first appeared.
            app.sub_app_mut(RenderApp)
                .insert_resource(labels.clone())
                .init_resource::<ShownNow>()
                .add_systems(
                    bevy::render::ExtractSchedule,
                    |showcase: bevy::render::Extract<Res<Showcase>>, mut now: ResMut<ShownNow>| {
                        now.0 = showcase.shown;
                    },
                )
                .add_systems(
                    bevy::render::Render,
                    (|cache: Res<PipelineCache>,
                      labels: Res<PipelineLabels>,
                      now: Res<ShownNow>| {
                        use bevy::render::render_resource::PipelineDescriptor as D;
                        let mut seen = labels.0.lock().unwrap();
                        for p in cache.pipelines() {
                            let label = match &p.descriptor {
                                D::RenderPipelineDescriptor(d) => d.label.clone(),
                                D::ComputePipelineDescriptor(d) => d.label.clone(),
                            };
                            if let Some(label) = label.filter(|l| plugin_of(l).is_some()) {
                                seen.entry(label.to_string()).or_insert(now.0);
                            }
                        }
                    })
                    .in_set(bevy::render::RenderSystems::Cleanup),
                );
        })
        .expect("render");
    let seen = seen.lock().unwrap().clone();
    let pipelines = pipelines.lock().unwrap().clone();
    (seen, pipelines, frame.to_rgba8())
}

/// Our pipelines the render world has queued so far, each with the scene
/// shown in the frame it first appeared.
#[derive(Resource, Clone, Default)]
struct PipelineLabels(Arc<Mutex<BTreeMap<String, Option<Scene>>>>);

/// The scene the frame being rendered shows.
#[derive(Resource, Default)]
struct ShownNow(Option<Scene>);

/// Through all five scenes and back: each scene, when shown again, has the
/// entities it had the first time (nothing of the others left, no twin or
/// clone kept), no plugin builds a pipeline while its scene is hidden, and
/// the last picture is the scene's own.
#[test]
fn switching_scenes_leaves_nothing_behind() {
    let mut order = Scene::ALL.to_vec();
    order.extend(Scene::ALL);
    order.push(Scene::Dome);
    let frames = 4;
    let (census, pipelines, picture) = switch_through(order.clone(), frames);
    assert_eq!(census.len(), order.len(), "{census:?}");
    for (i, (scene, c)) in order.iter().zip(&census).enumerate() {
        eprintln!(
            "{}: {} scene entities, (meshes, cameras, lights) {:?}",
            scene.name(),
            c.scene_entities,
            c.drawn,
        );
        assert!(c.scene_entities > 0, "{} spawned nothing", scene.name());
        let first = order.iter().position(|s| s == scene).unwrap();
        if first < i {
            let first = &census[first];
            assert_eq!(
                (c.scene_entities, c.drawn),
                (first.scene_entities, first.drawn),
                "{} shown again has other entities than the first time",
                scene.name()
            );
        }
    }
    // Every pipeline of ours was first queued in a frame that showed its
    // plugin's scene.
    eprintln!("{pipelines:?}");
    assert!(!pipelines.is_empty());
    for (label, shown) in &pipelines {
        assert_eq!(
            plugin_of(label),
            *shown,
            "{label} queued while {shown:?} was shown"
        );
    }
    // The dome drawn after every other scene is the dome drawn alone.
    let alone = headless(Scene::Dome)
        .render(|app| Scene::Dome.setup_alone(app, WIDTH))
        .expect("render")
        .to_rgba8();
    let psnr = optica_harness::metrics::psnr(&alone, &picture).expect("same size");
    eprintln!("dome after the others against the dome alone: PSNR {psnr:.1} dB");
    assert!(psnr >= 40.0, "PSNR {psnr} dB");
}

/// `OpticaPlugins` adds every plugin (their resources are there), and with
/// none of their components in the scene no plugin builds a pipeline.
#[test]
fn optica_plugins_add_every_plugin_and_build_nothing_unused() {
    use optica::prelude::*;
    let report = Headless::new(64, 64)
        .adapter(Adapter::Noop)
        .check_pipelines(|app| {
            app.add_plugins(OpticaPlugins).add_systems(
                Startup,
                |head: Option<Res<TrackedHead>>,
                 clock: Option<Res<optica::dome::DomeShowClock>>,
                 lenses: Option<Res<Assets<LensAsset>>>,
                 eyes: Option<Res<Assets<CompoundEyeMaterial>>>,
                 mut commands: Commands| {
                    assert!(head.is_some() && clock.is_some());
                    assert!(lenses.is_some() && eyes.is_some());
                    commands.spawn(Camera3d::default());
                },
            );
        })
        .expect("pipelines compile");
    let ours: Vec<_> = report
        .labels
        .iter()
        .filter(|l| plugin_of(l).is_some())
        .collect();
    assert!(ours.is_empty(), "{ours:?}");
}
