//! The harness' errors.

/// Why a headless run or a comparison failed.
#[derive(Debug, thiserror::Error)]
pub enum HarnessError {
    /// No adapter could be created (on Linux: install `mesa-vulkan-drivers`).
    #[error(
        "no render adapter: install a Vulkan driver (on headless Linux: apt-get install mesa-vulkan-drivers)"
    )]
    NoAdapter,
    /// The adapter asked for is not the one Bevy found (Bevy falls back to
    /// any adapter when the named one is missing).
    #[error("asked for adapter {wanted}, got {got}")]
    WrongAdapter {
        /// What was asked for.
        wanted: String,
        /// What the run got.
        got: String,
    },
    /// The noop backend could not be created.
    #[error("wgpu noop backend: {0}")]
    Noop(String),
    /// Pixels or timings were asked of the noop backend, which draws nothing.
    #[error(
        "the noop backend draws nothing: use Headless::check_pipelines, or another adapter for pixels and timings"
    )]
    NoPixelsOnNoop,
    /// A timing run of zero frames.
    #[error("a timing run needs at least one timed frame")]
    NoFrames,
    /// The requested size is zero or larger than the largest texture side.
    #[error("image size {0}×{1} is outside 1..={max}", max = crate::headless::MAX_SIDE)]
    BadSize(u32, u32),
    /// wgpu reported an error (validation, out of memory, device lost).
    #[error("wgpu error: {0}")]
    Wgpu(String),
    /// One or more pipelines failed to compile.
    #[error("pipelines failed to compile:\n{0}")]
    Pipelines(String),
    /// The app asked to exit (a system sent `AppExit`, or the render error handler did).
    #[error("the app asked to exit: {0}")]
    Exited(String),
    /// The texture readback never completed.
    #[error("the texture readback did not complete within {0} frames")]
    NoReadback(u32),
    /// The readback had an unexpected size.
    #[error("readback of {0} bytes, expected {1}")]
    BadReadback(usize, usize),
    /// Reading or writing a golden image failed.
    #[error("golden image {path}: {message}")]
    Golden {
        /// The file (or setting).
        path: String,
        /// What went wrong.
        message: String,
    },
}
