//! A soak with churn: one app with all five plugins, and every frame, at
//! random (seeded), one of: a camera spawned with one plugin's component
//! (lens flare, dome, spectacles, foveated tracer) into a free quarter of
//! the target, or despawned; a mesh spawned (a compound eye, a ray-traced
//! ball) or despawned; a live entity's settings redrawn over their whole
//! type range (sliders dragged to extremes, accepted or not); the lens
//! file overwritten (with random bytes one time in three) and hot-reloaded;
//! the tracker dropped or given a NaN; the target resized. A first phase
//! exercises every kind once; its end (churned entities despawned) is the
//! baseline.
//!
//! Asserted: no panic; no wgpu error (the harness records validation
//! errors); every read-back frame finite; when the churn stops, the main
//! world's entities and the render world's resources back to the baseline.
//! In a run of 5,000 frames or more, also: resident memory and GPU memory
//! over the last tenth of the frames peak within 5 % (plus 8 MiB for
//! allocator rounding) of the first tenth's after the baseline (printed,
//! not asserted, in a shorter run). `OPTICA_SOAK_FRAMES` frames (default
//! 240; `docs/reliability.md` gives the long command and its figures).

use bevy::camera::Viewport;
use bevy::prelude::*;
use bevy::render::RenderApp;
use optica_harness::randomise::randomise_some;
use optica_harness::{Headless, HeadlessRun};
use rand::{RngExt, SeedableRng};
use rand_xoshiro::SplitMix64;

use optica_compound_eye::{CompoundEye, CompoundEyeMaterial, CompoundEyePlugin};
use optica_dome::{DomeCamera, DomeMode, DomePlugin};
use optica_foveated_lod::{
    FoveatedLodPlugin, Foveation, GazeRayTracer, HeadSource, RayTraced, TrackedHead,
};
use optica_lens_flare::{FlareSource, LensFlare, LensFlarePlugin};
use optica_spectacles::{CloneDefocus, Eye, Spectacles, SpectaclesPlugin};

/// The quarter-target viewports (px) churned cameras draw into: they fit
/// the smallest target size the churn resizes to.
const QUARTER: u32 = 24;
const SIZES: [u32; 3] = [48, 56, 64];

/// The most churned meshes at once.
const MAX_MESHES: usize = 6;

fn frames() -> u32 {
    crate::count_from_env("OPTICA_SOAK_FRAMES", 240)
}

/// Marks what the churn made, with the quarter a camera draws into.
#[derive(Component)]
struct Churned {
    slot: Option<usize>,
}

/// The lens file the churn rewrites, in a folder of its own.
#[derive(Resource)]
struct HotLens {
    path: std::path::PathBuf,
    good: Vec<u8>,
    handle: Handle<optica_lens_flare::LensAsset>,
}

/// Resident set size of this process (bytes), from /proc.
fn rss_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|s| s.split_whitespace().nth(1)?.parse::<u64>().ok())
        .map_or(0, |pages| pages * 4096)
}

/// Pipelines in the render world's cache, by label.
fn pipelines(run: &mut HeadlessRun) -> std::collections::BTreeMap<String, usize> {
    let mut counts = std::collections::BTreeMap::new();
    let cache = run
        .app()
        .sub_app(RenderApp)
        .world()
        .resource::<bevy::render::render_resource::PipelineCache>();
    for p in cache.pipelines() {
        let label = match &p.descriptor {
            bevy::render::render_resource::PipelineDescriptor::RenderPipelineDescriptor(d) => {
                d.label.clone()
            }
            bevy::render::render_resource::PipelineDescriptor::ComputePipelineDescriptor(d) => {
                d.label.clone()
            }
        };
        *counts
            .entry(label.map_or("(unlabelled)".into(), |l| l.to_string()))
            .or_insert(0) += 1;
    }
    counts
}

fn render_resources(run: &mut HeadlessRun) -> usize {
    run.app()
        .sub_app(RenderApp)
        .world()
        .iter_resources()
        .count()
}

fn entities(run: &mut HeadlessRun) -> usize {
    run.app().world().entities().count_spawned() as usize
}

/// Every entity's components, by name, for a failure message about what
/// was left behind.
fn census(run: &mut HeadlessRun) -> std::collections::BTreeMap<String, usize> {
    let world = run.app().world_mut();
    let all: Vec<Entity> = world.query::<Entity>().iter(world).collect();
    let mut counts = std::collections::BTreeMap::new();
    for e in all {
        let mut names: Vec<String> = world
            .inspect_entity(e)
            .map(|it| it.map(|c| c.name().shortname().to_string()).collect())
            .unwrap_or_default();
        names.sort();
        *counts.entry(names.join(",")).or_insert(0) += 1;
    }
    counts
}

fn free_slot(world: &mut World) -> Option<usize> {
    let mut used = [false; 4];
    let mut q = world.query::<&Churned>();
    for c in q.iter(world) {
        if let Some(s) = c.slot {
            used[s] = true;
        }
    }
    used.iter().position(|u| !u)
}

fn viewport(slot: usize) -> Viewport {
    Viewport {
        physical_position: UVec2::new((slot as u32 % 2) * QUARTER, (slot as u32 / 2) * QUARTER),
        physical_size: UVec2::splat(QUARTER),
        ..default()
    }
}

/// One random change.
fn churn(world: &mut World, rng: &mut SplitMix64, target: &Handle<Image>) {
    let eye = Vec3::new(0.0, 0.8, 3.0);
    let camera = |slot: usize| {
        (
            Camera3d::default(),
            Camera {
                order: 1 + slot as isize,
                viewport: Some(viewport(slot)),
                clear_color: ClearColorConfig::Custom(Color::BLACK),
                ..default()
            },
            Transform::from_translation(eye).looking_at(Vec3::ZERO, Vec3::Y),
            Churned { slot: Some(slot) },
        )
    };
    let mut choice = rng.random_range(0..10);
    // (A subset of the changes, to find which one a regression comes from.)
    if let Ok(kinds) = std::env::var("OPTICA_SOAK_CHANGES") {
        let allowed: Vec<u32> = kinds.split(',').filter_map(|k| k.parse().ok()).collect();
        if !allowed.is_empty() && !allowed.contains(&choice) {
            choice = allowed[rng.random_range(0..allowed.len())];
        }
    }
    match choice {
        // A camera with one plugin's component.
        0 | 1 => {
            let Some(slot) = free_slot(world) else { return };
            let lens = world.resource::<HotLens>().handle.clone();
            let mut which = rng.random_range(0..4);
            // (One kind only, to find which one a regression comes from:
            // 0 flare, 1 dome, 2 spectacles, 3 tracer, 4 a plain camera.)
            if let Some(only) = std::env::var("OPTICA_SOAK_CAMERA")
                .ok()
                .and_then(|v| v.parse().ok())
            {
                which = only;
            }
            match which {
                0 => world.spawn((
                    camera(slot),
                    LensFlare {
                        grid: 8,
                        ..LensFlare::new(lens)
                    },
                )),
                1 => {
                    let mode = if rng.random() {
                        DomeMode::Vertex
                    } else {
                        DomeMode::CubeMap { face_px: 32 }
                    };
                    world.spawn((camera(slot), DomeCamera { mode, ..default() }))
                }
                2 => world.spawn((
                    camera(slot),
                    Eye::default(),
                    Spectacles::sphere(-2.0),
                    CloneDefocus::default(),
                )),
                3 => world.spawn((camera(slot), GazeRayTracer::default())),
                // A plain camera: the baseline of a memory comparison.
                _ => world.spawn(camera(slot)),
            };
        }
        // A mesh, up to `MAX_MESHES` churned ones, so that the scene's
        // size stays stationary and memory growth means a leak.
        2 => {
            let mut q = world.query::<&Churned>();
            if q.iter(world).filter(|c| c.slot.is_none()).count() >= MAX_MESHES {
                return;
            }
            let mesh = world
                .resource_mut::<Assets<Mesh>>()
                .add(Sphere::new(0.4).mesh().ico(2).unwrap());
            let at = Transform::from_xyz(
                rng.random_range(-1.0..1.0),
                0.5,
                rng.random_range(-1.0..1.0),
            );
            if rng.random() {
                let material =
                    world
                        .resource_mut::<Assets<CompoundEyeMaterial>>()
                        .add(CompoundEyeMaterial {
                            base: optica_report::fixtures::eye_base(),
                            extension: CompoundEye::default(),
                        });
                world.spawn((
                    Mesh3d(mesh),
                    MeshMaterial3d(material),
                    at,
                    Churned { slot: None },
                ));
            } else {
                world.spawn((
                    Mesh3d(mesh),
                    at,
                    RayTraced::diffuse(LinearRgba::rgb(0.6, 0.5, 0.4)),
                    Churned { slot: None },
                ));
            }
        }
        // Despawn one of the churned.
        3 => {
            let mut q = world.query_filtered::<Entity, With<Churned>>();
            let all: Vec<Entity> = q.iter(world).collect();
            if !all.is_empty() {
                let e = all[rng.random_range(0..all.len())];
                world.despawn(e);
            }
        }
        // Settings dragged anywhere.
        4..=6 => redraw_some(world, rng),
        // The lens file rewritten and reloaded: random bytes one time in three.
        7 => {
            let hot = world.resource::<HotLens>();
            let bytes: Vec<u8> = if rng.random_range(0..3) == 0 {
                (0..rng.random_range(0..400))
                    .map(|_| rng.random())
                    .collect()
            } else {
                hot.good.clone()
            };
            std::fs::write(&hot.path, bytes).expect("rewrite the lens");
            world.resource::<AssetServer>().reload("lenses/hot.lens");
        }
        // The tracker: lost, NaN, or back.
        8 => {
            let mut head = TrackedHead::looking(eye, Quat::IDENTITY, Some(Vec3::NEG_Z), 0.063);
            match rng.random_range(0..3) {
                0 => head.valid = false,
                1 => head.eyes[0] = Vec3::NAN,
                _ => {}
            }
            world.insert_resource(head);
        }
        // The target resized.
        _ => {
            let side = SIZES[rng.random_range(0..SIZES.len())];
            if let Some(mut image) = world.resource_mut::<Assets<Image>>().get_mut(target) {
                image.resize(bevy::render::render_resource::Extent3d {
                    width: side,
                    height: side,
                    depth_or_array_layers: 1,
                });
            }
        }
    }
}

/// Redraws a share of one live churned component's settings, or of the
/// foveation, over their whole range.
fn redraw_some(world: &mut World, rng: &mut SplitMix64) {
    let share = [0.05, 0.2, 1.0][rng.random_range(0..3)];
    let seed: u64 = rng.random();
    let mut draw = SplitMix64::seed_from_u64(seed);
    match rng.random_range(0..6) {
        0 => {
            let mut q = world.query::<&mut LensFlare>();
            if let Some(mut f) = q.iter_mut(world).next() {
                let lens = f.lens.clone();
                randomise_some(&mut *f, &mut draw, share);
                f.lens = lens;
                // Affordable on a CPU device.
                f.grid = f.grid.min(16);
                f.ghost_budget = f.ghost_budget.min(16);
            }
        }
        1 => {
            let mut q = world.query::<&mut DomeCamera>();
            if let Some(mut d) = q.iter_mut(world).next() {
                randomise_some(&mut *d, &mut draw, share);
                if let DomeMode::CubeMap { face_px } = &mut d.mode {
                    *face_px = (*face_px).min(64);
                }
            }
        }
        2 => {
            let mut q = world.query::<(&mut Eye, &mut Spectacles, &mut CloneDefocus)>();
            if let Some((mut e, mut s, mut c)) = q.iter_mut(world).next() {
                randomise_some(&mut *e, &mut draw, share);
                randomise_some(&mut *s, &mut draw, share);
                randomise_some(&mut *c, &mut draw, share);
                // The lens's tessellation stays affordable.
                s.tessellation = s.tessellation.min(UVec2::new(24, 64));
            }
        }
        3 => {
            let mut q = world.query::<&mut GazeRayTracer>();
            if let Some(mut t) = q.iter_mut(world).next() {
                randomise_some(&mut *t, &mut draw, share);
            }
        }
        4 => {
            let mut materials = world.resource_mut::<Assets<CompoundEyeMaterial>>();
            if let Some((_, m)) = materials.iter_mut().next() {
                randomise_some(&mut m.extension, &mut draw, share);
            }
        }
        _ => {
            let mut f = world.resource_mut::<Foveation>();
            randomise_some(&mut *f, &mut draw, share);
        }
    }
}

/// The churned cameras, for a failure message: slot, kind and settings.
fn cameras(world: &mut World) -> String {
    let mut q = world.query::<(
        &Churned,
        Option<&LensFlare>,
        Option<&DomeCamera>,
        Option<(&Eye, &Spectacles, &CloneDefocus)>,
        Option<&GazeRayTracer>,
    )>();
    q.iter(world)
        .filter(|c| c.0.slot.is_some())
        .map(|(c, f, d, s, t)| format!("\n  slot {:?}: {f:?} {d:?} {s:?} {t:?}", c.slot))
        .collect()
}

/// (RSS, GPU allocated) peaks of a window of frames.
#[derive(Default, Clone, Copy, Debug)]
struct Peaks {
    rss: u64,
    gpu: u64,
}

impl Peaks {
    fn add(&mut self, run: &HeadlessRun) {
        self.rss = self.rss.max(rss_bytes());
        self.gpu = self
            .gpu
            .max(run.gpu_memory().map_or(0, |(allocated, _)| allocated));
    }
}

/// The soak's app: all five plugins, a flaring sun, a ground both drawn
/// and ray traced, a plain camera owning the target, and the lens file in
/// a folder of its own (`dir`), which the churn rewrites.
fn start(dir: &std::path::Path) -> HeadlessRun {
    std::fs::create_dir_all(dir.join("lenses")).expect("temp dir");
    let good = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/lenses/tessar-us2854889.lens"
    ))
    .expect("lens");
    let path = dir.join("lenses/hot.lens");
    std::fs::write(&path, &good).expect("lens");
    let root: &'static str = Box::leak(dir.to_string_lossy().into_owned().into_boxed_str());
    let hot_path = path.clone();
    Headless::new(SIZES[2], SIZES[2])
        .hdr(true)
        .default_plugins(move |g| {
            g.set(bevy::asset::AssetPlugin {
                file_path: root.into(),
                ..default()
            })
        })
        .start(move |app: &mut App| {
            app.add_plugins((
                CompoundEyePlugin,
                DomePlugin,
                FoveatedLodPlugin,
                LensFlarePlugin,
                SpectaclesPlugin,
            ))
            .insert_resource(HeadSource::External)
            .insert_resource(TrackedHead::looking(
                Vec3::new(0.0, 0.8, 3.0),
                Quat::IDENTITY,
                Some(Vec3::NEG_Z),
                0.063,
            ))
            .add_systems(
                Startup,
                move |mut commands: Commands,
                      assets: Res<AssetServer>,
                      mut meshes: ResMut<Assets<Mesh>>,
                      mut materials: ResMut<Assets<StandardMaterial>>| {
                    commands.insert_resource(HotLens {
                        path: hot_path.clone(),
                        good: good.clone(),
                        handle: assets.load("lenses/hot.lens"),
                    });
                    commands.spawn((
                        DirectionalLight {
                            illuminance: 50_000.0,
                            shadow_maps_enabled: false,
                            ..default()
                        },
                        Transform::IDENTITY.looking_to(Vec3::new(0.1, -0.3, -1.0), Vec3::Y),
                        FlareSource::default(),
                    ));
                    commands.spawn((
                        Mesh3d(meshes.add(Plane3d::default().mesh().size(6.0, 6.0).build())),
                        MeshMaterial3d(materials.add(Color::srgb(0.5, 0.5, 0.45))),
                        RayTraced::diffuse(LinearRgba::rgb(0.5, 0.5, 0.45)),
                    ));
                    // The target's owner: a plain camera under the churned ones.
                    commands.spawn((
                        Camera3d::default(),
                        Transform::from_xyz(0.0, 2.0, 4.0).looking_at(Vec3::ZERO, Vec3::Y),
                    ));
                },
            );
        })
        .expect("app")
}

/// Despawns everything the churn made and puts the settings, the tracker
/// and the target's size back, then runs a few frames.
fn clear(run: &mut HeadlessRun, target: &Handle<Image>) {
    let world = run.app().world_mut();
    let mut q = world.query_filtered::<Entity, With<Churned>>();
    for e in q.iter(world).collect::<Vec<_>>() {
        world.despawn(e);
    }
    // Settings back to their defaults, the tracker back, the size back.
    world.insert_resource(Foveation::default());
    world.insert_resource(TrackedHead::looking(
        Vec3::new(0.0, 0.8, 3.0),
        Quat::IDENTITY,
        Some(Vec3::NEG_Z),
        0.063,
    ));
    let mut images = world.resource_mut::<Assets<Image>>();
    if let Some(mut image) = images.get_mut(target) {
        image.resize(bevy::render::render_resource::Extent3d {
            width: SIZES[2],
            height: SIZES[2],
            depth_or_array_layers: 1,
        });
    }
    for _ in 0..8 {
        run.step().expect("a frame after the churn");
    }
}

/// Reads the frame back; panics, naming the cameras, on a value that is
/// not finite.
fn check_frame(run: &mut HeadlessRun, k: u32) {
    let frame = run.frame().unwrap_or_else(|e| panic!("frame {k}: {e}"));
    let img = frame.hdr().expect("HDR");
    let bad: Vec<(u32, u32)> = img
        .enumerate_pixels()
        .filter(|(_, _, p)| p.0.iter().any(|v| !v.is_finite()))
        .map(|(x, y, _)| (x, y))
        .collect();
    if !bad.is_empty() {
        panic!(
            "frame {k}: {} pixels not finite, first {:?}; cameras: {}",
            bad.len(),
            &bad[..bad.len().min(4)],
            cameras(run.app().world_mut())
        );
    }
}

#[test]
fn a_churning_app_with_all_five_plugins_stays_finite_and_bounded() {
    let total = frames();
    let dir = std::env::temp_dir().join(format!("optica-soak-{}", std::process::id()));
    let mut run = start(&dir);
    let target = run.target();
    let mut rng = SplitMix64::seed_from_u64(0x50a4);
    run.step().expect("first frame");
    // Warm-up: every kind of change, then back to the scene alone.
    let warm = (total / 5).max(40);
    for k in 0..warm {
        churn(run.app().world_mut(), &mut rng, &target);
        run.step()
            .unwrap_or_else(|e| panic!("warm-up frame {k}: {e}"));
        if k % 20 == 19 {
            check_frame(&mut run, k);
        }
    }
    clear(&mut run, &target);
    let (entities0, resources0) = (entities(&mut run), render_resources(&mut run));
    let census0 = census(&mut run);
    // The soak.
    let soak = total - warm;
    let window = (soak / 10).max(1);
    let (mut first, mut last) = (Peaks::default(), Peaks::default());
    let (mut checked, mut most_entities) = (0, 0);
    for k in 0..soak {
        churn(run.app().world_mut(), &mut rng, &target);
        run.step().unwrap_or_else(|e| panic!("frame {k}: {e}"));
        if k % 20 == 19 {
            check_frame(&mut run, k);
            checked += 1;
        }
        most_entities = most_entities.max(entities(&mut run));
        if k % 100 == 99 {
            eprintln!(
                "soak frame {}: {} entities, RSS {:.1} MiB, GPU allocated {:.1} MiB, {} pipelines",
                k + 1,
                entities(&mut run),
                rss_bytes() as f64 / 1048576.0,
                run.gpu_memory().map_or(0, |g| g.0) as f64 / 1048576.0,
                pipelines(&mut run).values().sum::<usize>(),
            );
        }
        if k < window {
            first.add(&run);
        }
        if k >= soak - window {
            last.add(&run);
        }
    }
    check_frame(&mut run, soak);
    clear(&mut run, &target);
    let (entities1, resources1) = (entities(&mut run), render_resources(&mut run));
    let _ = std::fs::remove_dir_all(&dir);
    eprintln!(
        "soak: {total} frames ({warm} warm-up), {checked} frames read back finite; entities {entities0} → {entities1} (at most {most_entities}), \
         render resources {resources0} → {resources1}; RSS peak {:.1} → {:.1} MiB, GPU allocated peak {:.1} → {:.1} MiB",
        first.rss as f64 / 1048576.0,
        last.rss as f64 / 1048576.0,
        first.gpu as f64 / 1048576.0,
        last.gpu as f64 / 1048576.0
    );
    if entities1 != entities0 {
        let census1 = census(&mut run);
        let keys: std::collections::BTreeSet<&String> =
            census0.keys().chain(census1.keys()).collect();
        let grown: Vec<_> = keys
            .into_iter()
            .filter(|k| census0.get(*k) != census1.get(*k))
            .map(|k| {
                format!(
                    "{} (was {}) × [{k}]",
                    census1.get(k).copied().unwrap_or(0),
                    census0.get(k).copied().unwrap_or(0)
                )
            })
            .collect();
        panic!("entities after the churn: {entities0} → {entities1}; changed: {grown:#?}");
    }
    assert_eq!(
        resources1, resources0,
        "render-world resources after the churn"
    );
    // Memory is held to the bound in the long run only (5,000 frames or
    // more, `docs/reliability.md`): a CI-sized run's first tenth still meets
    // shader variants and cube faces for the first time. The long run does
    // not meet it today: resident memory grows by ~0.25 MB a frame for each
    // dome, spectacles or tracer view on lavapipe (GPU allocations stay
    // flat), a finding left open in the issue.
    if total >= 5000 {
        // 5 %, plus 8 MiB: the allocators round up by blocks.
        let bounded = |a: u64, b: u64| b <= a + a / 20 + (8 << 20);
        assert!(
            bounded(first.rss, last.rss),
            "RSS {} → {}",
            first.rss,
            last.rss
        );
        assert!(
            bounded(first.gpu, last.gpu),
            "GPU memory {} → {}",
            first.gpu,
            last.gpu
        );
    }
}
