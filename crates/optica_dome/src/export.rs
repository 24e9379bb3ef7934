//! A domemaster PNG sequence, frame by frame, for render farms: each frame
//! is a function of its number alone (the show clock), so a farm manager
//! (Flamenco, OpenCue, a Slurm array job) splits a show into frame ranges
//! and runs one process per range; the pieces fit together because frame
//! `n` is the same image whichever range rendered it.

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use bevy::app::AppExit;
use bevy::camera::RenderTarget;
use bevy::prelude::*;
use bevy::render::render_resource::{CachedPipelineState, PipelineCache};
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
use bevy::render::{Render, RenderApp, RenderSystems};
use bevy::shader::ShaderCacheError;

use optica_optics::input;

use crate::{DomeCamera, Error};

/// The show's clock: the frame being rendered and the frame rate. Animate
/// from [`DomeShowClock::seconds`] (not from `Time`) and every frame of an
/// export is reproducible on its own. [`DomeExportPlugin`] sets it; without
/// an export it stays at frame 0 unless your app advances it.
#[derive(Resource, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Resource)]
pub struct DomeShowClock {
    /// The frame number.
    pub frame: u32,
    /// Frames per second of the show.
    pub fps: f32,
}

impl Default for DomeShowClock {
    /// Frame 0 of a 30 fps show.
    fn default() -> Self {
        Self {
            frame: 0,
            fps: 30.0,
        }
    }
}

impl DomeShowClock {
    /// Show time of the frame, in seconds.
    pub fn seconds(&self) -> f32 {
        self.frame as f32 / self.fps
    }
}

/// What to export: the frames `frames` of the show, as
/// `dir/domemaster_NNNNNN.png` (the frame number, six digits), from the
/// first [`DomeCamera`]'s target. Give the camera an image target of the
/// size you want (up to 8K: 8192²), or let the plugin's window be that size.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct DomeExport {
    /// Folder the PNGs go to (created if missing).
    pub dir: PathBuf,
    /// Frame numbers to render, `start..end` (end excluded).
    pub frames: Range<u32>,
    /// Frames per second of the show (sets [`DomeShowClock::fps`]).
    pub fps: f32,
    /// Updates rendered on each frame before its capture that count as
    /// settled: every pipeline made (the export waits for pipelines still
    /// compiling or waiting for a shader, up to
    /// 600 updates) and no dome twin rebuilt in the
    /// update (the twins an update refines are drawn from the next one
    /// on). So each frame is captured from the same settled state whatever
    /// came before it, and frame `n` is the same image, bit for bit,
    /// whichever range rendered it. Each frame costs at least this many
    /// updates plus the one that moves the scene to it.
    pub warmup_updates: u32,
    /// Whether the app exits once the last frame is written.
    pub exit_when_done: bool,
}

impl DomeExport {
    /// Frames `frames` to `dir` at `fps`, exiting when done.
    pub fn new(dir: impl Into<PathBuf>, frames: Range<u32>, fps: f32) -> Self {
        Self {
            dir: dir.into(),
            frames,
            fps,
            warmup_updates: 2,
            exit_when_done: true,
        }
    }

    /// The PNG of frame `frame`.
    pub fn path_of(&self, frame: u32) -> PathBuf {
        self.dir.join(format!("domemaster_{frame:06}.png"))
    }

    /// The frames of [`DomeExport::frames`] with no finished PNG in
    /// [`DomeExport::dir`]: what a farm's final step reports, and what a
    /// rerun must render (see [`frame_ranges`] for the ranges to hand out
    /// again). A frame counts as written when its file starts with PNG's
    /// signature; the export writes each frame under another name and
    /// renames it when complete, so a task killed mid-write leaves its
    /// frame missing, not truncated.
    pub fn missing(&self) -> Vec<u32> {
        self.frames
            .clone()
            .filter(|&frame| !is_png(&self.path_of(frame)))
            .collect()
    }

    /// Checks the range, the rate and the folder (creating it).
    pub fn validate(&self) -> Result<(), Error> {
        if self.frames.is_empty() {
            return Err(Error::EmptyFrames(self.frames.clone()));
        }
        input::positive("frame rate (1/s)", f64::from(self.fps))?;
        std::fs::create_dir_all(&self.dir).map_err(|e| Error::CreateDir {
            dir: self.dir.clone(),
            message: e.to_string(),
        })
    }
}

/// Whether `path` is a file that starts with PNG's signature.
fn is_png(path: &Path) -> bool {
    use std::io::Read;
    const SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a];
    let mut head = [0u8; 8];
    std::fs::File::open(path)
        .and_then(|mut file| file.read_exact(&mut head))
        .is_ok_and(|()| head == SIGNATURE)
}

/// Sorted frame numbers grouped into ranges of consecutive frames
/// (`[4, 5, 9]` → `[4..6, 9..10]`): the `--frames` ranges a rerun renders.
///
/// ```
/// use optica_dome::frame_ranges;
/// assert_eq!(frame_ranges(&[4, 5, 9]), vec![4..6, 9..10]);
/// assert!(frame_ranges(&[]).is_empty());
/// ```
pub fn frame_ranges(frames: &[u32]) -> Vec<Range<u32>> {
    let mut ranges: Vec<Range<u32>> = Vec::new();
    for &frame in frames {
        match ranges.last_mut() {
            Some(last) if last.end == frame => last.end = frame.saturating_add(1),
            _ => ranges.push(frame..frame.saturating_add(1)),
        }
    }
    ranges
}

/// Writes a captured frame as `path`, through `path.part` renamed when
/// complete, so that no half-written PNG carries a frame's name.
fn write_frame(image: &Image, path: &Path) -> Result<(), String> {
    let rgba = image
        .clone()
        .try_into_dynamic()
        .map_err(|e| format!("frame not convertible to an image: {e}"))?;
    // The alpha channel holds no coverage here (as Bevy's own screenshot
    // saving does, it is dropped).
    let rgb = rgba.to_rgb8();
    let part = path.with_extension("png.part");
    rgb.save_with_format(&part, image::ImageFormat::Png)
        .map_err(|e| format!("{}: {e}", part.display()))?;
    std::fs::rename(&part, path).map_err(|e| format!("{}: {e}", path.display()))
}

/// Parses a frame range as a farm manager writes it: `A..B` (B excluded),
/// `A..=B` or a single frame `A`.
pub fn parse_frame_range(text: &str) -> Result<Range<u32>, Error> {
    let number = |s: &str| {
        s.trim().parse::<u32>().map_err(|_| Error::FrameNumber {
            part: s.to_string(),
            text: text.to_string(),
        })
    };
    let range = if let Some((a, b)) = text.split_once("..=") {
        number(a)?..number(b)?.saturating_add(1)
    } else if let Some((a, b)) = text.split_once("..") {
        number(a)?..number(b)?
    } else {
        let a = number(text)?;
        a..a.saturating_add(1)
    };
    if range.is_empty() {
        return Err(Error::EmptyFrames(range));
    }
    Ok(range)
}

/// How many updates the export waits for pipelines to be ready before it
/// gives up (and exits with an error when it exits when done): a shader
/// that never loads would otherwise hold the job forever.
pub const MAX_PIPELINE_WAIT_UPDATES: u32 = 600;

/// Renders [`DomeExport`]'s frames one by one: sets the show clock, waits
/// until every pipeline is ready and the frame has settled (see
/// [`DomeExport::warmup_updates`]), captures it, waits for the capture to
/// be written, moves on.
pub struct DomeExportPlugin(pub DomeExport);

/// Pipelines the render world's cache has not made yet (queued, compiling,
/// or waiting for a shader), as its last frame counted them; shared
/// between the main and the render world.
#[derive(Resource, Clone, Default, Debug)]
pub struct PendingPipelines(pub Arc<AtomicUsize>);

/// Counts the pipelines not yet made, at the end of each render.
fn count_pending_pipelines(cache: Res<PipelineCache>, pending: Res<PendingPipelines>) {
    let count = cache
        .pipelines()
        .filter(|p| match &p.state {
            CachedPipelineState::Ok(_) => false,
            // A shader still loading is retried by the cache.
            CachedPipelineState::Err(
                ShaderCacheError::ShaderNotLoaded(_)
                | ShaderCacheError::ShaderImportNotYetAvailable,
            ) => true,
            // A pipeline that failed for good will not be made: waiting
            // would not help (the cache logs why).
            CachedPipelineState::Err(_) => false,
            _ => true,
        })
        .count();
    pending.0.store(count, Ordering::Relaxed);
}

impl Plugin for DomeExportPlugin {
    fn build(&self, app: &mut App) {
        if let Err(why) = self.0.validate() {
            error!("optica_dome export: {why}; nothing is exported");
            return;
        }
        // Until the render world has counted, assume something is pending.
        let pending = PendingPipelines(Arc::new(AtomicUsize::new(usize::MAX)));
        match app.get_sub_app_mut(RenderApp) {
            Some(render_app) => {
                render_app.insert_resource(pending.clone()).add_systems(
                    Render,
                    count_pending_pipelines.in_set(RenderSystems::Cleanup),
                );
            }
            // Nothing renders, so nothing to wait for (and nothing to capture).
            None => pending.0.store(0, Ordering::Relaxed),
        }
        app.insert_resource(pending)
            .insert_resource(self.0.clone())
            .insert_resource(DomeShowClock {
                frame: self.0.frames.start,
                fps: self.0.fps,
            })
            .insert_resource(ExportState {
                next: self.0.frames.start,
                capturing: false,
                warmup: self.0.warmup_updates,
                waited: 0,
            })
            .add_systems(First, set_show_clock)
            .add_systems(Last, capture_frame);
    }
}

/// Where an export stands.
#[derive(Resource, Debug)]
pub struct ExportState {
    /// The frame being (or next to be) captured.
    pub next: u32,
    /// A capture of `next` is on its way.
    pub capturing: bool,
    /// Updates with every pipeline ready still to render before the capture.
    pub warmup: u32,
    /// Updates spent waiting for pipelines so far.
    pub waited: u32,
}

fn set_show_clock(state: Res<ExportState>, mut clock: ResMut<DomeShowClock>) {
    if clock.frame != state.next {
        clock.frame = state.next;
    }
}

fn capture_frame(
    mut commands: Commands,
    mut state: ResMut<ExportState>,
    export: Res<DomeExport>,
    pending: Res<PendingPipelines>,
    refined: Option<Res<crate::DomeRefineStats>>,
    cameras: Query<&RenderTarget, With<DomeCamera>>,
    mut exit: MessageWriter<AppExit>,
) {
    if state.capturing || state.next >= export.frames.end {
        return;
    }
    let waiting = pending.0.load(Ordering::Relaxed);
    if waiting > 0 {
        state.waited += 1;
        if state.waited == MAX_PIPELINE_WAIT_UPDATES {
            error!(
                "optica_dome export: {} pipelines still not ready after {MAX_PIPELINE_WAIT_UPDATES} updates; \
                 frame {} not written",
                if waiting == usize::MAX {
                    "the render world's".into()
                } else {
                    waiting.to_string()
                },
                state.next
            );
            if export.exit_when_done {
                exit.write(AppExit::error());
            }
        }
        return;
    }
    // An update that rebuilt twins has not settled: the twins it made are
    // drawn from the next one on.
    if refined.is_some_and(|r| r.rebuilt > 0) {
        return;
    }
    if state.warmup > 0 {
        state.warmup -= 1;
        return;
    }
    let Some(target) = cameras.iter().next() else {
        return;
    };
    let screenshot = match target {
        RenderTarget::Image(image) => Screenshot::image(image.handle.clone()),
        RenderTarget::Window(_) => Screenshot::primary_window(),
        other => {
            error!("optica_dome export: cannot capture a {other:?} target");
            return;
        }
    };
    let frame = state.next;
    state.capturing = true;
    commands.spawn(screenshot).observe(
        move |captured: On<ScreenshotCaptured>,
              mut state: ResMut<ExportState>,
              export: Res<DomeExport>,
              mut exit: MessageWriter<AppExit>| {
            // A frame that cannot be written fails the task (a farm sees
            // its exit status), rather than being skipped.
            if let Err(why) = write_frame(&captured.image, &export.path_of(frame)) {
                error!("optica_dome export: frame {frame} not written: {why}");
                if export.exit_when_done {
                    exit.write(AppExit::error());
                }
                return;
            }
            info!("optica_dome export: frame {frame} written");
            state.capturing = false;
            state.next = frame + 1;
            // Every frame settles as the first one does, so that its
            // image does not depend on the frame before it.
            state.warmup = export.warmup_updates;
            if state.next >= export.frames.end && export.exit_when_done {
                exit.write(AppExit::Success);
            }
        },
    );
}
