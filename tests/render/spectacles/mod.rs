//! The spectacles plugin on lavapipe: the clones' displacement against the
//! CPU twin, the blur that pixels show against the dioptric formula, the
//! correction by glasses, goldens, stability, and nothing built for a scene
//! without an eye.

mod blur;
mod correction;
mod parity;
mod pipelines;
mod presets;
mod refraction;
mod scene;
mod stability;

pub use scene::*;
