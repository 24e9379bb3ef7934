//! A domemaster PNG sequence, frame by frame, for render farms: each frame
//! is a function of its number alone (the show clock), so a farm manager
//! (Flamenco, OpenCue, a Slurm array job) splits a show into frame ranges
//! and runs one process per range; the pieces fit together because frame
//! `n` is the same image whichever range rendered it.

use std::ops::Range;
use std::path::PathBuf;

use bevy::app::AppExit;
use bevy::camera::RenderTarget;
use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured, save_to_disk};

use crate::DomeCamera;

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
    /// Updates rendered before the first capture, so that assets and
    /// pipelines are ready (2 is enough with synchronous pipeline
    /// compilation; raise it for asynchronous compilation).
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

    /// Checks the range, the rate and the folder (creating it).
    pub fn validate(&self) -> Result<(), String> {
        if self.frames.is_empty() {
            return Err(format!("empty frame range {:?}", self.frames));
        }
        if !(self.fps > 0.0 && self.fps.is_finite()) {
            return Err(format!("frame rate {} is not positive", self.fps));
        }
        std::fs::create_dir_all(&self.dir)
            .map_err(|e| format!("cannot create {}: {e}", self.dir.display()))
    }
}

/// Parses a frame range as a farm manager writes it: `A..B` (B excluded),
/// `A..=B` or a single frame `A`.
pub fn parse_frame_range(text: &str) -> Result<Range<u32>, String> {
    let number = |s: &str| {
        s.trim()
            .parse::<u32>()
            .map_err(|_| format!("`{s}` in frame range `{text}` is not a frame number"))
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
        return Err(format!("frame range `{text}` is empty"));
    }
    Ok(range)
}

/// Renders [`DomeExport`]'s frames one by one: sets the show clock, waits
/// for the frame's capture to be written, moves on.
pub struct DomeExportPlugin(pub DomeExport);

impl Plugin for DomeExportPlugin {
    fn build(&self, app: &mut App) {
        if let Err(why) = self.0.validate() {
            error!("optica_dome export: {why}; nothing is exported");
            return;
        }
        app.insert_resource(self.0.clone())
            .insert_resource(DomeShowClock {
                frame: self.0.frames.start,
                fps: self.0.fps,
            })
            .insert_resource(ExportState {
                next: self.0.frames.start,
                capturing: false,
                warmup: self.0.warmup_updates,
            })
            .add_systems(First, set_show_clock)
            .add_systems(Last, capture_frame);
    }
}

#[derive(Resource, Debug)]
struct ExportState {
    /// The frame being (or next to be) captured.
    next: u32,
    /// A capture of `next` is on its way.
    capturing: bool,
    warmup: u32,
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
    cameras: Query<&RenderTarget, With<DomeCamera>>,
) {
    if state.capturing || state.next >= export.frames.end {
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
    commands
        .spawn(screenshot)
        .observe(save_to_disk(export.path_of(frame)))
        .observe(
            move |_: On<ScreenshotCaptured>,
                  mut state: ResMut<ExportState>,
                  export: Res<DomeExport>,
                  mut exit: MessageWriter<AppExit>| {
                info!("optica_dome export: frame {frame} written");
                state.capturing = false;
                state.next = frame + 1;
                // The capture may arrive after this update's clock was set:
                // one whole update on the new frame before its capture.
                state.warmup = 1;
                if state.next >= export.frames.end && export.exit_when_done {
                    exit.write(AppExit::Success);
                }
            },
        );
}
