//! Running a Bevy app without a window and reading back what it rendered.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use bevy::{
    app::{PluginGroupBuilder, PluginsState},
    asset::RenderAssetUsages,
    camera::RenderTarget,
    prelude::*,
    render::{
        RenderApp, RenderPlugin,
        diagnostic::RenderDiagnosticsPlugin,
        error_handler::{RenderErrorHandler, RenderErrorPolicy},
        gpu_readback::{Readback, ReadbackComplete},
        pipelined_rendering::PipelinedRenderingPlugin,
        render_resource::{CachedPipelineState, PipelineCache, TextureFormat, TextureUsages},
        renderer::{RenderAdapterInfo, RenderDevice},
        settings::{RenderCreation, WgpuSettings},
    },
    shader::ShaderCacheError,
    time::TimeUpdateStrategy,
    window::ExitCondition,
};
use image::{Rgba32FImage, RgbaImage};

use crate::timing::{FrameTimings, PairedTimings, RatioInterval, SpanCollector, Stats};
use crate::{Adapter, AdapterInfo, HarnessError, Pixels, RenderedFrame};

/// A change to Bevy's `DefaultPlugins` before the app is built, e.g. an
/// asset folder or a default image sampler.
pub type PluginsHook = Arc<dyn Fn(PluginGroupBuilder) -> PluginGroupBuilder + Send + Sync>;

/// The largest image side a run accepts: wgpu's default `max_texture_dimension_2d`.
pub const MAX_SIDE: u32 = 8192;

/// The simulated time between frames unless [`Headless::time_step`] says
/// otherwise: 1/60 s, a common display rate, so animations advance the same
/// in every run whatever the machine's speed.
pub const DEFAULT_TIME_STEP: Duration = Duration::from_nanos(16_666_667);

/// Settings of a headless run. Build one with [`Headless::new`] and the
/// builder methods, then call [`Headless::render`],
/// [`Headless::check_pipelines`] or [`Headless::time_frames`].
///
/// Time is deterministic by default: every frame advances Bevy's `Time` by
/// [`DEFAULT_TIME_STEP`] (`TimeUpdateStrategy::ManualDuration`), so an
/// animated scene renders the same frame on every machine.
///
/// ```no_run
/// use bevy::prelude::*;
/// use optica_harness::Headless;
///
/// let frame = Headless::new(128, 128)
///     .frames(5)
///     .render(|app| {
///         app.add_systems(Startup, |mut commands: Commands| {
///             // A camera without an image target is pointed at the harness' image.
///             commands.spawn((Camera3d::default(), Transform::from_xyz(0.0, 0.0, 5.0)));
///         });
///     })
///     .expect("render");
/// println!("{} rendered {}×{}", frame.adapter, frame.width(), frame.height());
/// ```
#[derive(Clone)]
pub struct Headless {
    width: u32,
    height: u32,
    frames: u32,
    hdr: bool,
    pub(crate) adapter: Adapter,
    time_step: Option<Duration>,
    plugins: Option<PluginsHook>,
}

impl std::fmt::Debug for Headless {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Headless")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("frames", &self.frames)
            .field("hdr", &self.hdr)
            .field("adapter", &self.adapter)
            .field("time_step", &self.time_step)
            .field("plugins", &self.plugins.as_ref().map(|_| "hook"))
            .finish()
    }
}

/// What [`Headless::check_pipelines`] found.
#[derive(Clone, Debug)]
pub struct PipelineReport {
    /// The adapter that compiled them.
    pub adapter: AdapterInfo,
    /// Pipelines created successfully.
    pub ok: usize,
    /// Pipelines still queued or compiling after the run (none expected with
    /// synchronous compilation).
    pub pending: usize,
    /// Labels of the pipelines that compiled, in cache order (unlabelled ones
    /// as `(unlabelled)`), so a test can check which ones a scene built.
    pub labels: Vec<String>,
}

impl Headless {
    /// A run of `width`×`height` pixels, 3 frames, 8-bit, on lavapipe, with
    /// deterministic time.
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            frames: 3,
            hdr: false,
            adapter: Adapter::Software,
            time_step: Some(DEFAULT_TIME_STEP),
            plugins: None,
        }
    }

    /// Frames to run before the readback (at least 1). Pipelines compile
    /// synchronously, so one is often enough; animations and temporal effects need more.
    pub fn frames(mut self, frames: u32) -> Self {
        self.frames = frames.max(1);
        self
    }

    /// Reads back linear HDR floats (an `Rgba16Float` target; the harness
    /// turns tonemapping off on every camera) instead of 8-bit sRGB.
    pub fn hdr(mut self, hdr: bool) -> Self {
        self.hdr = hdr;
        self
    }

    /// Chooses the device. The run fails with [`HarnessError::WrongAdapter`]
    /// rather than silently use another one when the chosen one is missing.
    pub fn adapter(mut self, adapter: Adapter) -> Self {
        self.adapter = adapter;
        self
    }

    /// Advances Bevy's `Time` by `step` every frame
    /// (`TimeUpdateStrategy::ManualDuration`). The default is [`DEFAULT_TIME_STEP`].
    pub fn time_step(mut self, step: Duration) -> Self {
        self.time_step = Some(step);
        self
    }

    /// Lets Bevy's `Time` follow the wall clock, as in a real app: animated
    /// scenes then differ from run to run.
    pub fn real_time(mut self) -> Self {
        self.time_step = None;
        self
    }

    /// Changes Bevy's `DefaultPlugins` before the app is built: an asset
    /// folder, a default image sampler, a plugin disabled.
    ///
    /// ```no_run
    /// use bevy::prelude::*;
    /// use optica_harness::Headless;
    ///
    /// let headless = Headless::new(64, 64).default_plugins(|plugins| {
    ///     plugins
    ///         .set(AssetPlugin { file_path: "my_assets".into(), ..default() })
    ///         .set(ImagePlugin::default_nearest())
    /// });
    /// ```
    pub fn default_plugins(
        mut self,
        hook: impl Fn(PluginGroupBuilder) -> PluginGroupBuilder + Send + Sync + 'static,
    ) -> Self {
        self.plugins = Some(Arc::new(hook));
        self
    }

    /// The image width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// The image height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Builds the app, lets `setup` add plugins and systems, runs
    /// [`Headless::frames`] frames and reads the image back.
    ///
    /// Every camera that targets a window (the default) is redirected to the
    /// harness' image, so a scene's ordinary setup works unchanged.
    pub fn render(&self, setup: impl FnOnce(&mut App)) -> Result<RenderedFrame, HarnessError> {
        let _one_at_a_time = lock();
        if self.adapter == Adapter::Noop {
            return Err(HarnessError::NoPixelsOnNoop);
        }
        let (mut app, handle) = self.prepare(setup, false)?;
        for _ in 0..self.frames {
            step(&mut app)?;
        }
        settle(&mut app)?;
        let data = read_back(&mut app, handle)?;
        let pipelines = pipeline_states(&mut app)?.ok;
        let adapter = adapter_info(&mut app)?;
        let pixels = if self.hdr {
            Pixels::Hdr(decode_rgba16f(&data, self.width, self.height)?)
        } else {
            Pixels::Rgba8(decode_rgba8(&data, self.width, self.height)?)
        };
        Ok(RenderedFrame {
            adapter,
            pixels,
            pipelines,
        })
    }

    /// Builds the app and keeps it running, for a test that steps it, changes
    /// the scene and reads frames back as it goes (a soak, settings drawn
    /// at random frame after frame). [`Headless::frames`] is not used: the
    /// caller steps. Holds the harness' one-app-at-a-time lock until dropped.
    pub fn start(&self, setup: impl FnOnce(&mut App)) -> Result<HeadlessRun, HarnessError> {
        let guard = lock();
        if self.adapter == Adapter::Noop {
            return Err(HarnessError::NoPixelsOnNoop);
        }
        let (app, handle) = self.prepare(setup, false)?;
        Ok(HeadlessRun {
            app,
            handle,
            hdr: self.hdr,
            _one_at_a_time: guard,
        })
    }

    /// Runs the app for [`Headless::frames`] frames and checks that every
    /// pipeline compiled, that wgpu reported no error and that the app did
    /// not ask to exit. Works on [`Adapter::Noop`], where no driver exists.
    ///
    /// Cameras are pointed at an image target as in [`Headless::render`].
    pub fn check_pipelines(
        &self,
        setup: impl FnOnce(&mut App),
    ) -> Result<PipelineReport, HarnessError> {
        let _one_at_a_time = lock();
        let (mut app, _) = self.prepare(setup, false)?;
        for _ in 0..self.frames {
            step(&mut app)?;
        }
        settle(&mut app)?;
        let states = pipeline_states(&mut app)?;
        Ok(PipelineReport {
            adapter: adapter_info(&mut app)?,
            ok: states.ok,
            pending: states.pending,
            labels: states.labels,
        })
    }

    /// Times the scene: runs `warmup` frames, then `frames` timed frames,
    /// and returns the wall time of each frame (the app's update with the GPU
    /// waited for) and every render pass's time span, GPU time from timestamp
    /// queries where the adapter has them. See [`FrameTimings`].
    ///
    /// Passes record spans through Bevy's `RenderDiagnosticsPlugin`, which
    /// the harness adds: Bevy's own passes do, and so can yours:
    ///
    /// ```ignore
    /// let diagnostics = ctx.diagnostic_recorder();
    /// let diagnostics = diagnostics.as_deref();
    /// let span = diagnostics.time_span(ctx.command_encoder(), "my_plugin/my_pass");
    /// // ... encode the pass ...
    /// span.end(ctx.command_encoder());
    /// ```
    pub fn time_frames(
        &self,
        warmup: u32,
        frames: u32,
        setup: impl FnOnce(&mut App),
    ) -> Result<FrameTimings, HarnessError> {
        let _one_at_a_time = lock();
        if self.adapter == Adapter::Noop {
            return Err(HarnessError::NoPixelsOnNoop);
        }
        if frames == 0 {
            return Err(HarnessError::NoFrames);
        }
        let (mut app, _) = self.prepare(setup, true)?;
        let mut collector = warm_up(&mut app, warmup)?;
        let mut frame_ms = Vec::with_capacity(frames as usize);
        for _ in 0..frames {
            frame_ms.push(timed_step(&mut app, &mut collector)?);
        }
        finish_timings(&mut app, collector, frame_ms)
    }

    /// Times an effect against its baseline so that the machine's load
    /// cannot fake the ratio: the two scenes run as two apps side by side,
    /// both warmed up (`warmup` frames, then until no pipeline waits), then
    /// `blocks` blocks of `frames_per_block` frames each, alternating
    /// between them (effect then baseline, then baseline then effect, …, so
    /// that a drift in the machine's speed falls on both alike). Each block
    /// pair gives a ratio, the effect's median frame over the baseline's;
    /// [`PairedTimings::ratio`] is their median with a 95 % bootstrap
    /// interval. A goal such as "at most 2× the baseline" is met when the
    /// interval's upper bound is.
    ///
    /// ```no_run
    /// use bevy::prelude::*;
    /// use optica_harness::Headless;
    /// let timed = Headless::new(64, 64)
    ///     .time_paired(2, 8, 4, |app| { /* the scene with the effect */ }, |app| { /* without */ })
    ///     .unwrap();
    /// println!("{:.2}x [{:.2}, {:.2}]", timed.ratio.median, timed.ratio.low, timed.ratio.high);
    /// ```
    pub fn time_paired(
        &self,
        warmup: u32,
        blocks: u32,
        frames_per_block: u32,
        effect: impl FnOnce(&mut App),
        baseline: impl FnOnce(&mut App),
    ) -> Result<PairedTimings, HarnessError> {
        let started = std::time::Instant::now();
        let _one_at_a_time = lock();
        if self.adapter == Adapter::Noop {
            return Err(HarnessError::NoPixelsOnNoop);
        }
        if blocks == 0 || frames_per_block == 0 {
            return Err(HarnessError::NoFrames);
        }
        let mut apps = [
            self.prepare(effect, true)?.0,
            self.prepare(baseline, true)?.0,
        ];
        let mut collectors = [
            warm_up(&mut apps[0], warmup)?,
            warm_up(&mut apps[1], warmup)?,
        ];
        let mut frame_ms: [Vec<f64>; 2] = Default::default();
        let mut ratios = Vec::with_capacity(blocks as usize);
        for block in 0..blocks {
            let order = if block % 2 == 0 { [0, 1] } else { [1, 0] };
            let mut medians = [0.0; 2];
            for which in order {
                let mut times = Vec::with_capacity(frames_per_block as usize);
                for _ in 0..frames_per_block {
                    times.push(timed_step(&mut apps[which], &mut collectors[which])?);
                }
                medians[which] = Stats::of(&times).map_or(f64::NAN, |s| s.median);
                frame_ms[which].extend(times);
            }
            ratios.push(medians[0] / medians[1]);
        }
        let mut timings = Vec::with_capacity(2);
        for ((app, collector), frame_ms) in apps.iter_mut().zip(collectors).zip(frame_ms) {
            timings.push(finish_timings(app, collector, frame_ms)?);
        }
        let ratio = RatioInterval::bootstrap(&ratios).ok_or(HarnessError::NoFrames)?;
        let baseline = timings.pop().expect("two apps");
        let effect = timings.pop().expect("two apps");
        Ok(PairedTimings {
            effect,
            baseline,
            ratio,
            elapsed_s: started.elapsed().as_secs_f64(),
        })
    }

    /// The app with its target image, set up and finished, before any frame.
    fn prepare(
        &self,
        setup: impl FnOnce(&mut App),
        timing: bool,
    ) -> Result<(App, Handle<Image>), HarnessError> {
        if self.width == 0 || self.height == 0 || self.width > MAX_SIDE || self.height > MAX_SIDE {
            return Err(HarnessError::BadSize(self.width, self.height));
        }
        let mut app = self.build_app(timing)?;
        let format = if self.hdr {
            TextureFormat::Rgba16Float
        } else {
            TextureFormat::Rgba8UnormSrgb
        };
        let mut target = Image::new_target_texture(self.width, self.height, format, None);
        target.asset_usage = RenderAssetUsages::RENDER_WORLD;
        // The readback copies from the texture.
        target.texture_descriptor.usage |= TextureUsages::COPY_SRC;
        let handle = app.world_mut().resource_mut::<Assets<Image>>().add(target);
        app.insert_resource(HarnessTarget {
            image: handle.clone(),
            hdr: self.hdr,
        });
        app.add_systems(PreUpdate, hdr_cameras)
            .add_observer(retarget_on_insert);
        setup(&mut app);
        finish(&mut app)?;
        check_adapter(&self.adapter, &adapter_info(&mut app)?)?;
        Ok((app, handle))
    }

    pub(crate) fn build_app(&self, timing: bool) -> Result<App, HarnessError> {
        let render_creation = match &self.adapter {
            Adapter::Noop => crate::noop::render_creation()?,
            Adapter::Auto => RenderCreation::Automatic(Box::default()),
            Adapter::Software => RenderCreation::Automatic(Box::new(WgpuSettings {
                adapter_name: Some("llvmpipe".into()),
                ..default()
            })),
            Adapter::Named(name) => RenderCreation::Automatic(Box::new(WgpuSettings {
                adapter_name: Some(name.clone()),
                ..default()
            })),
        };
        let plugins = DefaultPlugins
            .build()
            .set(WindowPlugin {
                primary_window: None,
                exit_condition: ExitCondition::DontExit,
                ..default()
            })
            .set(RenderPlugin {
                render_creation,
                synchronous_pipeline_compilation: true,
                ..default()
            })
            // Frames must be finished when `update` returns, for a deterministic readback.
            .disable::<PipelinedRenderingPlugin>()
            // Several apps per test process: only one may own the global logger.
            .disable::<bevy::log::LogPlugin>();
        // (Bevy's log for one app, e.g. an example's headless run, when asked.)
        let plugins = if std::env::var_os("OPTICA_HARNESS_LOG").is_some() {
            plugins.enable::<bevy::log::LogPlugin>()
        } else {
            plugins
        };
        #[cfg(feature = "winit")]
        let plugins = plugins.disable::<bevy::winit::WinitPlugin>();
        let plugins = match &self.plugins {
            Some(hook) => hook(plugins),
            None => plugins,
        };
        let mut app = App::new();
        app.add_plugins(plugins);
        if timing {
            app.add_plugins(RenderDiagnosticsPlugin);
        }
        if let Some(step) = self.time_step {
            app.insert_resource(TimeUpdateStrategy::ManualDuration(step));
        }
        app.init_resource::<RenderErrors>();
        // Record wgpu errors instead of only logging them, so a test can say what failed.
        app.insert_resource(RenderErrorHandler(|error, main_world, _| {
            let source = error
                .source
                .as_ref()
                .map(|s| format!(" ({:?})", **s))
                .unwrap_or_default();
            main_world
                .resource_mut::<RenderErrors>()
                .0
                .push(format!("{:?}: {}{source}", error.ty, error.description));
            main_world.write_message(AppExit::error());
            RenderErrorPolicy::StopRendering
        }));
        Ok(app)
    }
}

/// A headless app kept running ([`Headless::start`]): step it, reach into
/// its world, read its frame back, ask how much GPU memory it holds.
pub struct HeadlessRun {
    app: App,
    handle: Handle<Image>,
    hdr: bool,
    _one_at_a_time: std::sync::MutexGuard<'static, ()>,
}

impl HeadlessRun {
    /// The app, to change its scene between frames.
    pub fn app(&mut self) -> &mut App {
        &mut self.app
    }

    /// One frame; an error when wgpu reported one (a validation error
    /// among them) or the app asked to exit.
    pub fn step(&mut self) -> Result<(), HarnessError> {
        step(&mut self.app)
    }

    /// Waits for pipelines still compiling, then reads the target back at
    /// its current size (the steps this takes are frames of the app).
    pub fn frame(&mut self) -> Result<RenderedFrame, HarnessError> {
        settle(&mut self.app)?;
        let size = self
            .app
            .world()
            .resource::<Assets<Image>>()
            .get(&self.handle)
            .map(|i| i.size())
            .ok_or(HarnessError::NoReadback(0))?;
        let data = read_back(&mut self.app, self.handle.clone())?;
        let pixels = if self.hdr {
            Pixels::Hdr(decode_rgba16f(&data, size.x, size.y)?)
        } else {
            Pixels::Rgba8(decode_rgba8(&data, size.x, size.y)?)
        };
        Ok(RenderedFrame {
            adapter: adapter_info(&mut self.app)?,
            pixels,
            pipelines: pipeline_states(&mut self.app)?.ok,
        })
    }

    /// The render target, to resize it (`Image::resize`): the cameras
    /// drawing into it follow.
    pub fn target(&self) -> Handle<Image> {
        self.handle.clone()
    }

    /// GPU memory the device's allocator holds (bytes allocated, bytes
    /// reserved), where the backend reports it (Vulkan and DX12 do).
    pub fn gpu_memory(&self) -> Option<(u64, u64)> {
        let device = self.app.world().get_resource::<RenderDevice>()?;
        let report = device.wgpu_device().generate_allocator_report()?;
        Some((report.total_allocated_bytes, report.total_reserved_bytes))
    }
}

/// Runs one headless app at a time per process: test threads would otherwise
/// start several renderers on the same cores and share Bevy's global task
/// pools. A panic in one run must not poison the others.
pub(crate) fn lock() -> std::sync::MutexGuard<'static, ()> {
    static LOCK: Mutex<()> = Mutex::new(());
    LOCK.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// wgpu errors seen during a run.
#[derive(Resource, Default)]
struct RenderErrors(Vec<String>);

/// The image that windowless cameras are redirected to.
#[derive(Resource)]
pub struct HarnessTarget {
    /// The render-target image.
    pub image: Handle<Image>,
    /// Whether it holds linear HDR floats.
    pub hdr: bool,
}

/// Points a camera at the harness' image the moment its target is set, so
/// a camera spawned at any point of a frame is drawn from its first frame:
/// Bevy works out a camera's target size when the camera is added or its
/// projection or target image changes, not when its `RenderTarget`
/// component changes, so a camera redirected a frame after it was added
/// would never be sized (and never drawn).
fn retarget_on_insert(
    insert: On<Insert, RenderTarget>,
    target: Res<HarnessTarget>,
    mut cameras: Query<&mut RenderTarget, With<Camera>>,
) {
    if let Ok(mut render_target) = cameras.get_mut(insert.entity)
        && matches!(*render_target, RenderTarget::Window(_))
    {
        *render_target = RenderTarget::Image(target.image.clone().into());
    }
}

/// In an HDR run, gives every camera an HDR target and no tonemapping
/// (their image target is set by [`retarget_on_insert`]).
fn hdr_cameras(
    target: Res<HarnessTarget>,
    ldr_cameras: Query<Entity, (With<Camera>, Without<bevy::camera::Hdr>)>,
    mut commands: Commands,
) {
    if target.hdr {
        for entity in &ldr_cameras {
            // Linear output: HDR intermediate and no tonemapping curve.
            commands.entity(entity).insert((
                bevy::camera::Hdr,
                bevy::core_pipeline::tonemapping::Tonemapping::None,
            ));
        }
    }
}

/// How long renderer creation may take before the harness gives up: lavapipe
/// starts in about a second; a missing driver never finishes.
const ADAPTER_TIMEOUT: Duration = Duration::from_secs(60);

pub(crate) fn finish(app: &mut App) -> Result<(), HarnessError> {
    // Renderer creation is asynchronous: wait for it like `App::run` would,
    // but not forever: with no adapter at all Bevy's creation task panics on
    // its own thread and the plugins never leave `Adding`.
    let started = std::time::Instant::now();
    while app.plugins_state() == PluginsState::Adding {
        if started.elapsed() > ADAPTER_TIMEOUT {
            return Err(HarnessError::NoAdapter);
        }
        bevy::tasks::tick_global_task_pools_on_main_thread();
        std::thread::yield_now();
    }
    app.finish();
    app.cleanup();
    if app.get_sub_app(RenderApp).is_none() {
        return Err(HarnessError::NoAdapter);
    }
    Ok(())
}

/// Bevy falls back to any adapter when the named one is missing; a golden
/// image or a timing from the wrong device must fail instead.
pub(crate) fn check_adapter(wanted: &Adapter, got: &AdapterInfo) -> Result<(), HarnessError> {
    let ok = match wanted {
        Adapter::Software => got.name.to_lowercase().contains("llvmpipe"),
        Adapter::Named(name) => got.name.to_lowercase().contains(&name.to_lowercase()),
        Adapter::Auto | Adapter::Noop => true,
    };
    if ok {
        Ok(())
    } else {
        Err(HarnessError::WrongAdapter {
            wanted: format!("{wanted:?}"),
            got: got.summary(),
        })
    }
}

pub(crate) fn step(app: &mut App) -> Result<(), HarnessError> {
    app.update();
    if let Some(device) = app.world().get_resource::<RenderDevice>() {
        let _ = device.wgpu_device().poll(wgpu::PollType::Wait {
            submission_index: None,
            timeout: None,
        });
    }
    let errors = &app.world().resource::<RenderErrors>().0;
    if !errors.is_empty() {
        return Err(HarnessError::Wgpu(errors.join("; ")));
    }
    if let Some(exit) = app.should_exit() {
        return Err(HarnessError::Exited(format!("{exit:?}")));
    }
    Ok(())
}

/// The readback is copied in the frame after it is requested and mapped
/// asynchronously: a few frames at most.
const READBACK_FRAMES: u32 = 8;

fn read_back(app: &mut App, handle: Handle<Image>) -> Result<Vec<u8>, HarnessError> {
    let received: Arc<Mutex<Option<Vec<u8>>>> = Arc::default();
    let sink = received.clone();
    app.world_mut().spawn(Readback::texture(handle)).observe(
        move |event: On<ReadbackComplete>, mut commands: Commands| {
            *sink.lock().unwrap_or_else(|p| p.into_inner()) = Some(event.data.clone());
            commands.entity(event.entity).despawn();
        },
    );
    for _ in 0..READBACK_FRAMES {
        step(app)?;
        if let Some(data) = received.lock().unwrap_or_else(|p| p.into_inner()).take() {
            return Ok(data);
        }
    }
    Err(HarnessError::NoReadback(READBACK_FRAMES))
}

/// Runs `warmup` untimed frames and then until no pipeline waits; the span
/// collector to time the frames after them with.
fn warm_up(app: &mut App, warmup: u32) -> Result<SpanCollector, HarnessError> {
    for _ in 0..warmup {
        step(app)?;
    }
    settle(app)?;
    let mut collector = SpanCollector::default();
    // Spans of warm-up frames still arrive in the first timed frames:
    // start from whatever the store holds now.
    collector.skip_seen(app.world());
    Ok(collector)
}

/// One timed frame: its wall time (ms), its spans collected.
fn timed_step(app: &mut App, collector: &mut SpanCollector) -> Result<f64, HarnessError> {
    let started = std::time::Instant::now();
    step(app)?;
    let ms = started.elapsed().as_secs_f64() * 1e3;
    collector.collect(app.world());
    Ok(ms)
}

/// The timings of the frames timed so far. Diagnostics are read back
/// asynchronously, one to three frames late: untimed frames run until every
/// span has caught up.
fn finish_timings(
    app: &mut App,
    mut collector: SpanCollector,
    frame_ms: Vec<f64>,
) -> Result<FrameTimings, HarnessError> {
    let frames = frame_ms.len();
    for _ in 0..crate::timing::MAX_DIAGNOSTIC_LAG_FRAMES {
        if collector.complete(frames) {
            break;
        }
        step(app)?;
        collector.collect(app.world());
    }
    Ok(FrameTimings::new(
        adapter_info(app)?,
        frame_ms,
        collector.finish(frames),
    ))
}

/// How many extra frames a run waits for pipelines whose shaders are still
/// loading: embedded shaders load on the IO task pool, which a busy machine
/// (parallel tests on two cores) can delay by a few frames.
pub const MAX_SETTLE_FRAMES: u32 = 120;

/// Steps until no pipeline waits for a shader (or [`MAX_SETTLE_FRAMES`]),
/// so a frame is never read back or timed with meshes missing.
fn settle(app: &mut App) -> Result<(), HarnessError> {
    for _ in 0..MAX_SETTLE_FRAMES {
        if pipeline_states(app)?.pending == 0 {
            return Ok(());
        }
        step(app)?;
    }
    Ok(())
}

struct PipelineStates {
    ok: usize,
    pending: usize,
    labels: Vec<String>,
}

fn pipeline_states(app: &mut App) -> Result<PipelineStates, HarnessError> {
    let render = app.get_sub_app(RenderApp).ok_or(HarnessError::NoAdapter)?;
    let cache = render.world().resource::<PipelineCache>();
    let mut states = PipelineStates {
        ok: 0,
        pending: 0,
        labels: Vec::new(),
    };
    let mut errors = Vec::new();
    for pipeline in cache.pipelines() {
        match &pipeline.state {
            CachedPipelineState::Ok(_) => {
                states.ok += 1;
                states.labels.push(pipeline_label(&pipeline.descriptor));
            }
            // A shader still loading is retried by the cache: pending, not failed.
            CachedPipelineState::Err(
                ShaderCacheError::ShaderNotLoaded(_)
                | ShaderCacheError::ShaderImportNotYetAvailable,
            ) => states.pending += 1,
            CachedPipelineState::Err(e) => {
                errors.push(format!("{}: {e}", pipeline_label(&pipeline.descriptor)))
            }
            _ => states.pending += 1,
        }
    }
    if !errors.is_empty() {
        return Err(HarnessError::Pipelines(errors.join("\n")));
    }
    Ok(states)
}

fn pipeline_label(descriptor: &bevy::render::render_resource::PipelineDescriptor) -> String {
    use bevy::render::render_resource::PipelineDescriptor as D;
    let label = match descriptor {
        D::RenderPipelineDescriptor(d) => d.label.clone(),
        D::ComputePipelineDescriptor(d) => d.label.clone(),
    };
    label.map_or_else(|| "(unlabelled)".into(), |l| l.to_string())
}

pub(crate) fn adapter_info(app: &mut App) -> Result<AdapterInfo, HarnessError> {
    let info = app
        .get_sub_app(RenderApp)
        .and_then(|r| r.world().get_resource::<RenderAdapterInfo>())
        .or_else(|| app.world().get_resource::<RenderAdapterInfo>())
        .ok_or(HarnessError::NoAdapter)?;
    Ok(AdapterInfo::from_wgpu(info))
}

/// Readback rows are padded to 256 bytes (wgpu's `COPY_BYTES_PER_ROW_ALIGNMENT`); strip the padding.
pub(crate) fn unpad(
    data: &[u8],
    width: u32,
    height: u32,
    bytes_per_pixel: u32,
) -> Result<Vec<u8>, HarnessError> {
    let row = (width * bytes_per_pixel) as usize;
    let padded = row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as usize)
        * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as usize;
    let h = height as usize;
    if data.len() == row * h {
        return Ok(data.to_vec());
    }
    if h == 0 || data.len() < padded * (h - 1) + row {
        return Err(HarnessError::BadReadback(data.len(), row * h));
    }
    Ok((0..h)
        .flat_map(|y| data[y * padded..y * padded + row].iter().copied())
        .collect())
}

fn decode_rgba8(data: &[u8], width: u32, height: u32) -> Result<RgbaImage, HarnessError> {
    let bytes = unpad(data, width, height, 4)?;
    RgbaImage::from_raw(width, height, bytes).ok_or(HarnessError::BadReadback(
        data.len(),
        (width * height * 4) as usize,
    ))
}

fn decode_rgba16f(data: &[u8], width: u32, height: u32) -> Result<Rgba32FImage, HarnessError> {
    let bytes = unpad(data, width, height, 8)?;
    let floats: Vec<f32> = bytes
        .chunks_exact(2)
        .map(|h| half::f16::from_le_bytes([h[0], h[1]]).to_f32())
        .collect();
    Rgba32FImage::from_raw(width, height, floats).ok_or(HarnessError::BadReadback(
        data.len(),
        (width * height * 8) as usize,
    ))
}
