//! The lens-flare plugin on lavapipe: the trace shader against its CPU
//! twin, lens assets and the choice of ghosts.

mod aperture;
mod frame;
mod ghosts;
mod goldens;
mod parity;
mod passes;
mod stability;
mod trace;
