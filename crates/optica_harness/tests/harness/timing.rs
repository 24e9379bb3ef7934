//! GPU timing of a pass: a plugin's own render pass records a time span,
//! and the harness times it next to Bevy's passes.

use bevy::core_pipeline::{Core3d, Core3dSystems};
use bevy::prelude::*;
use bevy::render::{
    RenderApp,
    diagnostic::RecordDiagnostics,
    render_resource::{
        Extent3d, LoadOp, Operations, RenderPassColorAttachment, RenderPassDescriptor, StoreOp,
        Texture, TextureDescriptor, TextureDimension, TextureFormat, TextureUsages,
        TextureViewDescriptor,
    },
    renderer::{RenderContext, ViewQuery},
    view::ViewTarget,
};
use optica_harness::{Headless, TimeSource};

/// "Your plugin": one render pass per camera that clears a 1024² scratch
/// texture (real GPU work, no pipeline needed), inside a time span.
struct ClearPassPlugin;

impl Plugin for ClearPassPlugin {
    fn build(&self, app: &mut App) {
        app.sub_app_mut(RenderApp)
            .add_systems(Core3d, clear_pass.in_set(Core3dSystems::PostProcess));
    }
}

fn clear_pass(
    _view: ViewQuery<&ViewTarget>,
    mut scratch: Local<Option<Texture>>,
    mut ctx: RenderContext,
) {
    let texture = scratch.get_or_insert_with(|| {
        ctx.render_device().create_texture(&TextureDescriptor {
            label: Some("clear_pass scratch"),
            size: Extent3d {
                width: 1024,
                height: 1024,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: TextureDimension::D2,
            format: TextureFormat::Rgba8Unorm,
            usage: TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        })
    });
    let view = texture.create_view(&TextureViewDescriptor::default());
    // The recorder is there when RenderDiagnosticsPlugin is (the harness adds
    // it for timing runs); without it the span costs nothing.
    let diagnostics = ctx.diagnostic_recorder();
    let diagnostics = diagnostics.as_deref();
    // One span around one clear (the first touches the texture and costs
    // more), another around the same clear again, and one span recorded
    // twice in the frame (as a pass that runs once per view records it),
    // each time around the same clear.
    for name in [
        "my_plugin/clear",
        "my_plugin/clear_again",
        "my_plugin/clear_twice",
        "my_plugin/clear_twice",
    ] {
        let span = diagnostics.time_span(ctx.command_encoder(), name);
        ctx.command_encoder()
            .begin_render_pass(&RenderPassDescriptor {
                label: Some(name),
                color_attachments: &[Some(RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: Operations {
                        load: LoadOp::Clear(Default::default()),
                        store: StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
        span.end(ctx.command_encoder());
    }
}

fn scene(app: &mut App) {
    app.add_systems(
        Startup,
        |mut commands: Commands,
         mut meshes: ResMut<Assets<Mesh>>,
         mut materials: ResMut<Assets<StandardMaterial>>| {
            commands.spawn((
                Mesh3d(meshes.add(Sphere::new(1.0))),
                MeshMaterial3d(materials.add(Color::WHITE)),
            ));
            commands.spawn((
                DirectionalLight {
                    shadow_maps_enabled: false,
                    ..default()
                },
                Transform::from_xyz(1.0, 2.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
            ));
            commands.spawn((
                Camera3d::default(),
                Transform::from_xyz(0.0, 0.0, 4.0).looking_at(Vec3::ZERO, Vec3::Y),
            ));
        },
    );
}

#[test]
fn a_plugin_pass_is_timed_on_the_gpu() {
    let timings = Headless::new(128, 128)
        .time_frames(3, 10, |app| {
            scene(app);
            app.add_plugins(ClearPassPlugin);
        })
        .expect("timing run");
    eprintln!(
        "{} frame {:.2} ms",
        timings.adapter, timings.frame_ms.median
    );
    for s in &timings.spans {
        eprintln!(
            "  {:<28} gpu {:?} cpu {:?}",
            s.name,
            s.gpu_ms.map(|m| m.median),
            s.cpu_ms.map(|m| m.median)
        );
    }
    assert_eq!(timings.frame_ms.n, 10);
    assert!(timings.frame_ms.median > 0.0 && timings.frame_ms.min <= timings.frame_ms.median);
    // lavapipe has timestamp queries: the pass gets a real GPU time.
    let pass = timings
        .pass("my_plugin/clear")
        .expect("the clear pass recorded no span");
    assert_eq!(
        pass.source,
        TimeSource::GpuTimestamps,
        "{}: no timestamp queries",
        timings.adapter
    );
    assert!(pass.ms.median > 0.0 && pass.ms.n == 10, "{:?}", pass.ms);
    // Clearing 4 MB is less than the whole frame.
    assert!(
        pass.ms.median < timings.frame_ms.median,
        "{:?} vs frame {:?}",
        pass.ms,
        timings.frame_ms
    );
    // A span recorded twice in a frame counts both: about twice one clear's
    // time (the last one alone would be about one).
    let once = timings.pass("my_plugin/clear_again").expect("the span");
    let twice = timings
        .pass("my_plugin/clear_twice")
        .expect("the twice-recorded span");
    assert_eq!(twice.ms.n, 10, "one value per frame: {:?}", twice.ms);
    assert!(
        twice.ms.median > 1.3 * once.ms.median,
        "twice {:?} vs once {:?}",
        twice.ms,
        once.ms
    );
    // Bevy's own passes are timed the same way.
    assert!(
        timings.pass("main_opaque_pass_3d").is_some(),
        "{:?}",
        timings.spans
    );
}

#[test]
fn a_pass_that_did_not_run_has_no_time() {
    let timings = Headless::new(64, 64)
        .time_frames(1, 3, scene)
        .expect("timing run");
    assert!(timings.pass("my_plugin/clear").is_none());
    assert!(timings.span("main_opaque_pass_3d").is_some());
}

/// The main pass's counts of a unit sphere `distance` units out.
fn sphere_counts(distance: f32) -> std::collections::BTreeMap<String, f64> {
    let timings = Headless::new(128, 128)
        .time_frames(2, 4, move |app: &mut App| {
            scene(app);
            app.add_systems(
                PostStartup,
                move |mut cameras: Query<&mut Transform, With<Camera3d>>| {
                    for mut t in &mut cameras {
                        *t =
                            Transform::from_xyz(0.0, 0.0, distance).looking_at(Vec3::ZERO, Vec3::Y);
                    }
                },
            );
        })
        .expect("timing run");
    let main = timings
        .span("main_opaque_pass_3d")
        .expect("Bevy's main pass recorded no span");
    eprintln!(
        "{}: sphere {distance} out, main pass counts {:?}",
        timings.adapter, main.counts
    );
    main.counts
        .iter()
        .map(|(k, v)| (k.clone(), v.median))
        .collect()
}

#[test]
fn a_pass_span_counts_the_work_of_its_shaders() {
    // lavapipe has pipeline-statistics queries, and Bevy's main pass
    // records its span with `pass_span`.
    let near = sphere_counts(4.0);
    let far = sphere_counts(8.0);
    let count = |c: &std::collections::BTreeMap<String, f64>, name: &str| {
        *c.get(name).unwrap_or_else(|| panic!("no {name} in {c:?}"))
    };
    // The sphere's image is a disk of radius 64 · tan(asin(1/d)) /
    // tan(22.5°) px (Bevy's 45° field): ~5,000 px at 4 units, ~1,200 at
    // 8. Every covered pixel is shaded at least once, and the nearer,
    // larger image costs more. (lavapipe counts whole 4×4 blocks per
    // triangle, so the count is not proportional to the area: 19,696 and
    // 10,048 here.)
    let disk = |d: f64| {
        let r = 64.0 * (1.0 / d).asin().tan() / 22.5f64.to_radians().tan();
        std::f64::consts::PI * r * r
    };
    let (n, f) = (
        count(&near, "fragment_shader_invocations"),
        count(&far, "fragment_shader_invocations"),
    );
    assert!(n >= disk(4.0) && f >= disk(8.0), "{n} and {f} fragments");
    assert!(n > 1.5 * f, "{n} fragments near, {f} far");
    // The same mesh is drawn: as many vertices either way.
    assert!(count(&near, "vertex_shader_invocations") > 100.0);
    assert_eq!(
        count(&near, "vertex_shader_invocations"),
        count(&far, "vertex_shader_invocations")
    );
    // A render pass counts no compute shaders (Bevy records that count
    // for compute passes).
    assert!(!near.contains_key("compute_shader_invocations"), "{near:?}");
}

/// An effect that can only add cost, timed against its baseline in
/// alternating blocks: a system that busy-waits 20 ms a frame over a frame
/// of a few ms. Its ratio's whole interval lies above 1, and the same scene
/// against itself gives an interval around 1; both apps' frames and the
/// effect's pass spans are kept.
#[test]
fn an_effect_against_its_baseline_in_alternating_blocks() {
    fn busy(_: Query<&Camera>) {
        let start = std::time::Instant::now();
        while start.elapsed() < std::time::Duration::from_millis(20) {
            std::hint::spin_loop();
        }
    }
    let headless = Headless::new(64, 64);
    let timed = headless
        .time_paired(
            2,
            6,
            2,
            |app| {
                scene(app);
                app.add_plugins(ClearPassPlugin).add_systems(Update, busy);
            },
            scene,
        )
        .expect("paired run");
    let r = timed.ratio;
    eprintln!(
        "busy effect: {:.2} [{:.2}, {:.2}] over {} blocks, frames {:.2} / {:.2} ms, {:.1} s",
        r.median,
        r.low,
        r.high,
        r.blocks,
        timed.effect.frame_ms.median,
        timed.baseline.frame_ms.median,
        timed.elapsed_s
    );
    assert_eq!(r.blocks, 6);
    assert_eq!(
        (timed.effect.frame_ms.n, timed.baseline.frame_ms.n),
        (12, 12)
    );
    assert!(r.low > 1.0, "an effect that adds 20 ms a frame: {r:?}");
    assert!(r.low <= r.median && r.median <= r.high);
    assert!(timed.effect.span("my_plugin/clear").is_some());
    assert!(timed.baseline.span("my_plugin/clear").is_none());

    let same = headless
        .time_paired(2, 6, 2, scene, scene)
        .expect("paired run")
        .ratio;
    eprintln!(
        "same scene: {:.2} [{:.2}, {:.2}]",
        same.median, same.low, same.high
    );
    assert!(same.low < 1.5 && same.high > 0.67, "{same:?}");
    assert!(matches!(
        headless.time_paired(1, 0, 2, scene, scene),
        Err(optica_harness::HarnessError::NoFrames)
    ));
}
