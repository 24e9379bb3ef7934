//! One module per sweep. Each exposes `pub fn run(ctx: &SweepContext) -> Report`
//! and is listed in [`SWEEPS`] under the name the command line takes.

use crate::{Report, SweepContext};

pub mod compound_eye;
pub mod dome;
pub mod foveated_lod;
pub mod lens_flare;
pub mod optics;
pub mod spectacles;

/// A named sweep.
pub type SweepFn = fn(&SweepContext) -> Report;

/// Every sweep the runner knows, in the order `all` runs them.
pub const SWEEPS: &[(&str, SweepFn)] = &[
    ("optics", optics::run),
    ("foveated_lod", foveated_lod::run),
    ("compound_eye", compound_eye::run),
    ("lens_flare", lens_flare::run),
    ("spectacles", spectacles::run),
    ("dome", dome::run),
];
