//! Running a Bevy app without a window and reading back what it rendered.

use std::sync::{Arc, Mutex};

use bevy::{
    app::PluginsState,
    asset::RenderAssetUsages,
    camera::RenderTarget,
    prelude::*,
    render::{
        RenderApp, RenderPlugin,
        error_handler::{RenderErrorHandler, RenderErrorPolicy},
        gpu_readback::{Readback, ReadbackComplete},
        pipelined_rendering::PipelinedRenderingPlugin,
        render_resource::{CachedPipelineState, PipelineCache, TextureFormat},
        renderer::{RenderAdapterInfo, RenderDevice},
        settings::{RenderCreation, WgpuSettings},
    },
    window::ExitCondition,
};

use crate::HarnessError;

/// Which device renders.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum Adapter {
    /// Mesa's lavapipe (`llvmpipe`), the CPU Vulkan device. The default, so that
    /// golden images are produced by the same rasteriser on every machine.
    #[default]
    Software,
    /// Whatever adapter wgpu picks first (a GPU where there is one).
    Auto,
    /// An adapter whose name contains this string.
    Named(String),
    /// wgpu's noop backend: shaders and pipelines are validated, nothing is
    /// drawn. For [`Headless::check_pipelines`] on machines with no driver.
    Noop,
}

/// Settings of a headless run. Build one, then call [`Headless::render`] or
/// [`Headless::check_pipelines`].
///
/// ```no_run
/// use bevy::prelude::*;
/// use optica_harness::Headless;
///
/// let frame = Headless::new(128, 128)
///     .render(|app| {
///         app.add_systems(Startup, |mut commands: Commands| {
///             // Any camera without an image target is pointed at the harness' image.
///             commands.spawn((Camera3d::default(), Transform::from_xyz(0.0, 0.0, 5.0)));
///         });
///     })
///     .expect("render");
/// println!("{} rendered {}×{}", frame.adapter, frame.width, frame.height);
/// ```
#[derive(Clone, Debug)]
pub struct Headless {
    /// Width of the rendered image in pixels.
    pub width: u32,
    /// Height of the rendered image in pixels.
    pub height: u32,
    /// Frames to run before reading back (pipelines compile synchronously, so
    /// one is often enough; animations and temporal effects need more).
    pub frames: u32,
    /// Read back linear HDR floats (an `Rgba16Float` target, no tonemapping
    /// applied by the harness) instead of 8-bit sRGB.
    pub hdr: bool,
    /// Which device renders.
    pub adapter: Adapter,
}

/// What a headless run produced.
#[derive(Clone, Debug)]
pub struct RenderedFrame {
    /// Adapter name and backend, e.g. `llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan)`.
    pub adapter: String,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// The 8-bit sRGB image (present when `hdr` was false).
    pub rgba8: Option<image::RgbaImage>,
    /// Linear RGBA floats, row-major (present when `hdr` was true).
    pub hdr: Option<Vec<[f32; 4]>>,
    /// Number of render pipelines that compiled.
    pub pipelines: usize,
}

impl RenderedFrame {
    /// The 8-bit image; for an HDR frame, its values clamped to [0, 1] and
    /// encoded as sRGB.
    pub fn to_rgba8(&self) -> image::RgbaImage {
        if let Some(img) = &self.rgba8 {
            return img.clone();
        }
        let px = self.hdr.as_deref().unwrap_or(&[]);
        image::RgbaImage::from_fn(self.width, self.height, |x, y| {
            let p = px[(y * self.width + x) as usize];
            let enc = |v: f32| (linear_to_srgb(v.clamp(0.0, 1.0)) * 255.0 + 0.5) as u8;
            image::Rgba([enc(p[0]), enc(p[1]), enc(p[2]), (p[3].clamp(0.0, 1.0) * 255.0 + 0.5) as u8])
        })
    }
}

/// What [`Headless::check_pipelines`] found.
#[derive(Clone, Debug)]
pub struct PipelineReport {
    /// Adapter name and backend.
    pub adapter: String,
    /// Pipelines created successfully.
    pub ok: usize,
    /// Pipelines still queued or compiling after the run (none expected with
    /// synchronous compilation).
    pub pending: usize,
}

impl Headless {
    /// A run of `width`×`height` pixels, 3 frames, 8-bit, on lavapipe.
    pub fn new(width: u32, height: u32) -> Self {
        Self { width, height, frames: 3, hdr: false, adapter: Adapter::Software }
    }

    /// Sets the number of frames to run before the readback.
    pub fn frames(mut self, frames: u32) -> Self {
        self.frames = frames.max(1);
        self
    }

    /// Reads back linear HDR floats.
    pub fn hdr(mut self, hdr: bool) -> Self {
        self.hdr = hdr;
        self
    }

    /// Chooses the device.
    pub fn adapter(mut self, adapter: Adapter) -> Self {
        self.adapter = adapter;
        self
    }

    /// Builds the app, lets `setup` add plugins and systems, runs
    /// [`Headless::frames`] frames and reads the image back.
    ///
    /// Every `Camera` that targets a window (the default) is redirected to the
    /// harness' image, so a scene's ordinary setup works unchanged.
    pub fn render(&self, setup: impl FnOnce(&mut App)) -> Result<RenderedFrame, HarnessError> {
        let _one_at_a_time = lock();
        if self.adapter == Adapter::Noop {
            return Err(HarnessError::NoPixelsOnNoop);
        }
        if self.width == 0 || self.height == 0 || self.width > 8192 || self.height > 8192 {
            return Err(HarnessError::BadSize(self.width, self.height));
        }
        let mut app = self.build_app()?;
        let format = if self.hdr { TextureFormat::Rgba16Float } else { TextureFormat::Rgba8UnormSrgb };
        let mut target = Image::new_target_texture(self.width, self.height, format, None);
        target.asset_usage = RenderAssetUsages::RENDER_WORLD;
        // The readback copies from the texture.
        target.texture_descriptor.usage |= bevy::render::render_resource::TextureUsages::COPY_SRC;
        let handle = app.world_mut().resource_mut::<Assets<Image>>().add(target);
        app.insert_resource(HarnessTarget { image: handle.clone(), hdr: self.hdr });
        app.add_systems(PreUpdate, retarget_cameras);
        setup(&mut app);
        finish(&mut app)?;

        for _ in 0..self.frames {
            step(&mut app)?;
        }
        let received: Arc<Mutex<Option<Vec<u8>>>> = Arc::default();
        let sink = received.clone();
        app.world_mut().spawn(Readback::texture(handle)).observe(
            move |event: On<ReadbackComplete>, mut commands: Commands| {
                *sink.lock().unwrap() = Some(event.data.clone());
                commands.entity(event.entity).despawn();
            },
        );
        // The readback is copied in the frame after it is requested and mapped
        // asynchronously: a few frames at most.
        for _ in 0..8 {
            step(&mut app)?;
            if received.lock().unwrap().is_some() {
                break;
            }
        }
        let data = received.lock().unwrap().take().ok_or(HarnessError::NoReadback)?;
        let pipelines = pipeline_states(&mut app)?.ok;
        let adapter = adapter_name(&mut app);
        let (rgba8, hdr) = if self.hdr {
            (None, Some(decode_rgba16f(&data, self.width, self.height)?))
        } else {
            (Some(decode_rgba8(&data, self.width, self.height)?), None)
        };
        Ok(RenderedFrame { adapter, width: self.width, height: self.height, rgba8, hdr, pipelines })
    }

    /// Runs the app for [`Headless::frames`] frames and checks that every
    /// pipeline compiled, that wgpu reported no error and that the app did
    /// not ask to exit. Works on [`Adapter::Noop`], where no driver exists.
    ///
    /// Cameras are pointed at a small image target as in [`Headless::render`].
    pub fn check_pipelines(&self, setup: impl FnOnce(&mut App)) -> Result<PipelineReport, HarnessError> {
        let _one_at_a_time = lock();
        let mut app = self.build_app()?;
        let mut target = Image::new_target_texture(self.width.max(1), self.height.max(1), TextureFormat::Rgba8UnormSrgb, None);
        target.asset_usage = RenderAssetUsages::RENDER_WORLD;
        let handle = app.world_mut().resource_mut::<Assets<Image>>().add(target);
        app.insert_resource(HarnessTarget { image: handle, hdr: false });
        app.add_systems(PreUpdate, retarget_cameras);
        setup(&mut app);
        finish(&mut app)?;
        for _ in 0..self.frames {
            step(&mut app)?;
        }
        let states = pipeline_states(&mut app)?;
        Ok(PipelineReport { adapter: adapter_name(&mut app), ok: states.ok, pending: states.pending })
    }

    fn build_app(&self) -> Result<App, HarnessError> {
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
            .set(WindowPlugin { primary_window: None, exit_condition: ExitCondition::DontExit, ..default() })
            .set(RenderPlugin { render_creation, synchronous_pipeline_compilation: true, ..default() })
            // Frames must be finished when `update` returns, for a deterministic readback.
            .disable::<PipelinedRenderingPlugin>()
            // Several apps per test process: only one may own the global logger.
            .disable::<bevy::log::LogPlugin>();
        #[cfg(feature = "winit")]
        let plugins = plugins.disable::<bevy::winit::WinitPlugin>();
        let mut app = App::new();
        app.add_plugins(plugins);
        app.init_resource::<RenderErrors>();
        // Record wgpu errors instead of only logging them, so a test can say what failed.
        app.insert_resource(RenderErrorHandler(|error, main_world, _| {
            let source = error.source.as_ref().map(|s| format!(" ({:?})", **s)).unwrap_or_default();
            main_world.resource_mut::<RenderErrors>().0.push(format!("{:?}: {}{source}", error.ty, error.description));
            main_world.write_message(AppExit::error());
            RenderErrorPolicy::StopRendering
        }));
        Ok(app)
    }
}

/// Runs one headless app at a time per process: test threads would otherwise
/// start several renderers on the same two cores and share Bevy's global task
/// pools. A panic in one run must not poison the others.
fn lock() -> std::sync::MutexGuard<'static, ()> {
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

fn retarget_cameras(
    target: Res<HarnessTarget>,
    mut cameras: Query<&mut RenderTarget, With<Camera>>,
    ldr_cameras: Query<Entity, (With<Camera>, Without<bevy::camera::Hdr>)>,
    mut commands: Commands,
) {
    for mut render_target in &mut cameras {
        if matches!(*render_target, RenderTarget::Window(_)) {
            *render_target = RenderTarget::Image(target.image.clone().into());
        }
    }
    if target.hdr {
        for entity in &ldr_cameras {
            // Linear output: HDR intermediate and no tonemapping curve.
            commands.entity(entity).insert((bevy::camera::Hdr, bevy::core_pipeline::tonemapping::Tonemapping::None));
        }
    }
}

/// How long renderer creation may take before the harness gives up.
const ADAPTER_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(60);

fn finish(app: &mut App) -> Result<(), HarnessError> {
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

fn step(app: &mut App) -> Result<(), HarnessError> {
    app.update();
    if let Some(device) = app.world().get_resource::<RenderDevice>() {
        let _ = device.wgpu_device().poll(wgpu::PollType::Wait { submission_index: None, timeout: None });
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

struct PipelineStates {
    ok: usize,
    pending: usize,
}

fn pipeline_states(app: &mut App) -> Result<PipelineStates, HarnessError> {
    let render = app.get_sub_app(RenderApp).ok_or(HarnessError::NoAdapter)?;
    let cache = render.world().resource::<PipelineCache>();
    let mut ok = 0;
    let mut pending = 0;
    let mut errors = Vec::new();
    for pipeline in cache.pipelines() {
        match &pipeline.state {
            CachedPipelineState::Ok(_) => ok += 1,
            CachedPipelineState::Err(e) => errors.push(format!("{}: {e}", pipeline_label(&pipeline.descriptor))),
            _ => pending += 1,
        }
    }
    if !errors.is_empty() {
        return Err(HarnessError::Pipelines(errors.join("\n")));
    }
    Ok(PipelineStates { ok, pending })
}

fn pipeline_label(descriptor: &bevy::render::render_resource::PipelineDescriptor) -> String {
    use bevy::render::render_resource::PipelineDescriptor as D;
    let label = match descriptor {
        D::RenderPipelineDescriptor(d) => d.label.clone(),
        D::ComputePipelineDescriptor(d) => d.label.clone(),
    };
    label.map_or_else(|| "(unlabelled pipeline)".into(), |l| l.to_string())
}

fn adapter_name(app: &mut App) -> String {
    let info = app
        .get_sub_app(RenderApp)
        .and_then(|r| r.world().get_resource::<RenderAdapterInfo>())
        .or_else(|| app.world().get_resource::<RenderAdapterInfo>());
    match info {
        Some(info) => format!("{} ({:?})", info.name, info.backend),
        None => "unknown".into(),
    }
}

/// Readback rows are padded to 256 bytes; strip the padding.
fn unpad(data: &[u8], width: u32, height: u32, bytes_per_pixel: u32) -> Result<Vec<u8>, HarnessError> {
    let row = (width * bytes_per_pixel) as usize;
    let padded = row.div_ceil(256) * 256;
    let h = height as usize;
    if data.len() == row * h {
        return Ok(data.to_vec());
    }
    if data.len() < padded * (h - 1) + row {
        return Err(HarnessError::BadReadback(data.len(), row * h));
    }
    Ok((0..h).flat_map(|y| data[y * padded..y * padded + row].iter().copied()).collect())
}

fn decode_rgba8(data: &[u8], width: u32, height: u32) -> Result<image::RgbaImage, HarnessError> {
    let bytes = unpad(data, width, height, 4)?;
    image::RgbaImage::from_raw(width, height, bytes).ok_or(HarnessError::BadReadback(data.len(), (width * height * 4) as usize))
}

fn decode_rgba16f(data: &[u8], width: u32, height: u32) -> Result<Vec<[f32; 4]>, HarnessError> {
    let bytes = unpad(data, width, height, 8)?;
    Ok(bytes
        .chunks_exact(8)
        .map(|p| {
            let c = |i: usize| f16_to_f32(u16::from_le_bytes([p[2 * i], p[2 * i + 1]]));
            [c(0), c(1), c(2), c(3)]
        })
        .collect())
}

/// IEEE 754 half to single precision (subnormals, infinities and NaN included).
pub(crate) fn f16_to_f32(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = ((h >> 10) & 0x1f) as i32;
    let frac = (h & 0x3ff) as f32;
    match exp {
        0 => sign * frac * 2f32.powi(-24),
        31 if frac == 0.0 => sign * f32::INFINITY,
        31 => f32::NAN,
        _ => sign * (1.0 + frac / 1024.0) * 2f32.powi(exp - 15),
    }
}

/// The sRGB transfer function.
pub fn linear_to_srgb(v: f32) -> f32 {
    if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_floats_decode() {
        assert_eq!(f16_to_f32(0x3c00), 1.0);
        assert_eq!(f16_to_f32(0xc000), -2.0);
        assert_eq!(f16_to_f32(0x3800), 0.5);
        assert_eq!(f16_to_f32(0x0001), 2f32.powi(-24));
        assert!(f16_to_f32(0x7c00).is_infinite());
        assert!(f16_to_f32(0x7e00).is_nan());
    }

    #[test]
    fn padded_rows_are_stripped() {
        // 3 px of 4 bytes = 12 bytes a row, padded to 256.
        let mut data = vec![0u8; 256 * 2];
        data[..12].copy_from_slice(&[1; 12]);
        data[256..268].copy_from_slice(&[2; 12]);
        let out = unpad(&data, 3, 2, 4).unwrap();
        assert_eq!(out.len(), 24);
        assert!(out[..12].iter().all(|&b| b == 1) && out[12..].iter().all(|&b| b == 2));
    }
}
