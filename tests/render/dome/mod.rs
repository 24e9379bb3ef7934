//! The dome camera on lavapipe: the WGSL projection against its CPU twin,
//! a scene seen through the dome, and nothing built without a dome camera.

mod pipelines;
mod projection;
mod scene;
mod stability;
