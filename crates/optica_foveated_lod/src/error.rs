//! The crate's one error type: every refusal of the plugin, by where it
//! comes from.

use optica_optics::foveated_lod::FoveatedError;
use thiserror::Error;

use crate::LodError;
use crate::dtrack::DTrackError;
use crate::trace::TraceError;

/// Why the foveated LOD refused something: a setting or a wall the optics
/// cannot use ([`CaveViewStatus::error`](crate::CaveViewStatus)), a mesh
/// without an LOD chain, a head trace that cannot be read, a tracker
/// datagram. Each source's own error converts into it, so `?` carries any
/// of them:
///
/// ```
/// use optica_foveated_lod::{Error, HeadTrace};
///
/// fn load(csv: &str) -> Result<HeadTrace, Error> {
///     Ok(HeadTrace::from_csv(csv.as_bytes())?)
/// }
/// assert!(matches!(load("t,head_x\n0,1\n"), Err(Error::Trace(_))));
/// ```
#[derive(Debug, Error)]
pub enum Error {
    /// A number, field or wall the optics refuses.
    #[error(transparent)]
    Optics(#[from] FoveatedError),
    /// A mesh that cannot be simplified into an LOD chain.
    #[error(transparent)]
    Lod(#[from] LodError),
    /// A head trace file that cannot be read.
    #[error(transparent)]
    Trace(#[from] TraceError),
    /// A DTrack datagram refused, or its socket not bound.
    #[error(transparent)]
    DTrack(#[from] DTrackError),
}
