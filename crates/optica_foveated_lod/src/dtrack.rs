//! A real tracker's stream: ART DTrack's ASCII output over UDP, the
//! optical tracking most CAVEs use, read into [`TrackedHead`].
//!
//! No Rust crate reads DTrack or VRPN (on crates.io, 2026-12-05: there is
//! no `vrpn`, and `dtrack` is an unrelated Dependency-Track client), so
//! this module parses DTrack's documented ASCII datagrams itself. A datagram holds one measurement frame, one line per
//! kind of data:
//!
//! ```text
//! fr 21753
//! ts 39596.024
//! 6d 1 [0 1.000][326.848 -187.216 -7.977 0.0000 0.0000 30.0000][0.866025 0.500000 0.000000 -0.500000 0.866025 0.000000 0.000000 0.000000 1.000000]
//! ```
//!
//! `fr` is the frame counter, `ts` the timestamp (s), and `6d` the tracked
//! 6DOF bodies: their count, then per body `[id quality]`, `[x y z η θ φ]`
//! (position in mm, Euler angles in degrees, unused here) and the 3×3
//! rotation matrix `[b0 … b8]` given column by column, which turns the
//! body's axes into the room's. A body the tracker does not see is not
//! listed. Other lines (`6dcal`, `3d`, `gl`, `6df2`, …) are skipped.
//!
//! [`HeadSource::DTrack`](crate::HeadSource::DTrack) binds a UDP socket,
//! reads every datagram that arrived since the last frame, and writes the
//! head from the newest one: the body's position (mm → m) and rotation,
//! mapped into the scene by [`DTrackSettings::calibration`] (the room's
//! frame to the scene's: ART's default room frame has +Z up, Bevy's +Y, so
//! a Z-up room needs a −90° turn about X) and [`DTrackSettings::body_to_head`]
//! (the target's axes to the head's: −Z forward, +Y up). A frame without
//! the body makes the head [`lost`](TrackedHead::lost) (the dropout policy
//! holds the gaze, then gives full quality). A malformed datagram is
//! counted in [`DTrackStats`] and dropped; it never panics.

use std::net::{SocketAddr, UdpSocket};

use bevy::prelude::*;
use thiserror::Error;

use crate::head::TrackedHead;

/// The most bodies a `6d` line may claim: DTrack tracks a few dozen at
/// most; a larger count is refused before anything is allocated for it.
pub const MAX_BODIES: usize = 256;

/// Datagrams read per frame at most (the newest one is used; the rest are
/// counted as skipped).
pub const MAX_DATAGRAMS_PER_FRAME: usize = 256;

/// One tracked 6DOF body of a DTrack frame.
#[derive(Clone, Debug, PartialEq)]
pub struct DTrackBody {
    /// The body's number (from 0).
    pub id: u32,
    /// Quality, 0..=1 as DTrack reports it.
    pub quality: f32,
    /// Position in the room (mm).
    pub position_mm: Vec3,
    /// Rotation from the body's axes to the room's.
    pub rotation: Mat3,
}

/// One parsed DTrack datagram.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DTrackFrame {
    /// The frame counter (`fr`), if given.
    pub frame: Option<u64>,
    /// The timestamp in seconds (`ts`), if given.
    pub timestamp_s: Option<f64>,
    /// The tracked 6DOF bodies (`6d`).
    pub bodies: Vec<DTrackBody>,
}

/// Why a DTrack datagram was refused (the line, from 1, and what is
/// wrong), or why the stream could not be opened.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum DTrackError {
    /// The UDP socket could not be bound.
    #[error("cannot bind {addr}: {message}")]
    Bind {
        /// The address asked for.
        addr: SocketAddr,
        /// The system's words.
        message: String,
    },
    /// The datagram is not UTF-8 text.
    #[error("DTrack datagram is not text")]
    NotText,
    /// A line is malformed.
    #[error("DTrack datagram, line {line} (`{kind}`): {what}")]
    Line {
        /// Line number, from 1.
        line: usize,
        /// The line's kind (`fr`, `ts`, `6d`).
        kind: String,
        /// What is wrong.
        what: String,
    },
}

impl DTrackFrame {
    /// Parses one datagram.
    pub fn parse(datagram: &[u8]) -> Result<Self, DTrackError> {
        let text = std::str::from_utf8(datagram).map_err(|_| DTrackError::NotText)?;
        let mut frame = DTrackFrame::default();
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            let (kind, rest) = line.split_once(char::is_whitespace).unwrap_or((line, ""));
            let bad = |what: String| DTrackError::Line {
                line: i + 1,
                kind: kind.to_string(),
                what,
            };
            match kind {
                "fr" => {
                    frame.frame = Some(
                        rest.trim()
                            .parse()
                            .map_err(|_| bad(format!("`{}` is not a frame number", rest.trim())))?,
                    )
                }
                "ts" => {
                    let t: f64 = rest
                        .trim()
                        .parse()
                        .map_err(|_| bad(format!("`{}` is not a time", rest.trim())))?;
                    if !t.is_finite() {
                        return Err(bad(format!("time {t} is not finite")));
                    }
                    frame.timestamp_s = Some(t);
                }
                "6d" => frame.bodies = parse_6d(rest).map_err(bad)?,
                _ => {}
            }
        }
        Ok(frame)
    }
}

/// `N [id q][x y z η θ φ][b0 … b8] …`
fn parse_6d(rest: &str) -> Result<Vec<DTrackBody>, String> {
    let rest = rest.trim();
    let (count, mut blocks) = rest.split_once('[').map_or((rest, ""), |(c, b)| (c, b));
    let count: usize = count
        .trim()
        .parse()
        .map_err(|_| format!("`{}` is not a body count", count.trim()))?;
    if count > MAX_BODIES {
        return Err(format!("{count} bodies is more than {MAX_BODIES}"));
    }
    // The first block's `[` was split off above.
    let mut next_block = |first: bool| -> Result<Vec<f64>, String> {
        let body = if first {
            blocks
        } else {
            blocks
                .trim_start()
                .strip_prefix('[')
                .ok_or("a `[` is missing")?
        };
        let (inside, after) = body.split_once(']').ok_or("a `]` is missing")?;
        blocks = after;
        inside
            .split_whitespace()
            .map(|w| {
                w.parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or(format!("`{w}` is not a finite number"))
            })
            .collect()
    };
    let mut bodies = Vec::with_capacity(count);
    for k in 0..count {
        let id_q = next_block(k == 0)?;
        let pose = next_block(false)?;
        let m = next_block(false)?;
        if id_q.len() != 2 || pose.len() != 6 || m.len() != 9 {
            return Err(format!(
                "body {k}: blocks of {}, {} and {} numbers, not 2, 6 and 9",
                id_q.len(),
                pose.len(),
                m.len()
            ));
        }
        if id_q[0] < 0.0 || id_q[0].fract() != 0.0 || id_q[0] > u32::MAX as f64 {
            return Err(format!("body {k}: `{}` is not a body number", id_q[0]));
        }
        let col = |c: usize| Vec3::new(m[3 * c] as f32, m[3 * c + 1] as f32, m[3 * c + 2] as f32);
        bodies.push(DTrackBody {
            id: id_q[0] as u32,
            quality: id_q[1] as f32,
            position_mm: Vec3::new(pose[0] as f32, pose[1] as f32, pose[2] as f32),
            rotation: Mat3::from_cols(col(0), col(1), col(2)),
        });
    }
    if !blocks.trim().is_empty() {
        return Err(format!("more blocks than {count} bodies"));
    }
    Ok(bodies)
}

/// Where the DTrack stream comes in and how it maps into the scene.
#[derive(Clone, Debug, PartialEq)]
pub struct DTrackSettings {
    /// The address the UDP socket binds (DTrack's output port is set in
    /// DTrack; 5000 is common). `127.0.0.1:0` takes any free port.
    pub bind: SocketAddr,
    /// The head target's body number.
    pub body: u32,
    /// The tracker's room frame (metres, after mm → m) into the scene's.
    pub calibration: Transform,
    /// The target's axes into the head's (−Z forward, +Y up, +X right):
    /// how the target sits on the glasses.
    pub body_to_head: Quat,
    /// Interpupillary distance (m).
    pub ipd: f32,
}

impl Default for DTrackSettings {
    /// Port 5000 on every interface, body 0, a Z-up room turned Y-up, the
    /// target's axes the head's, 63 mm between the eyes.
    fn default() -> Self {
        Self {
            bind: SocketAddr::from(([0, 0, 0, 0], 5000)),
            body: 0,
            calibration: Transform::from_rotation(Quat::from_rotation_x(
                -std::f32::consts::FRAC_PI_2,
            )),
            body_to_head: Quat::IDENTITY,
            ipd: 0.063,
        }
    }
}

impl DTrackSettings {
    /// The head a tracked body gives.
    pub fn head_of(&self, body: &DTrackBody, timestamp_s: Option<f64>) -> TrackedHead {
        let position = self.calibration.transform_point(body.position_mm / 1000.0);
        let rotation = Quat::from_mat3(&body.rotation);
        let orientation = (self.calibration.rotation * rotation * self.body_to_head).normalize();
        let mut head = TrackedHead::looking(position, orientation, None, self.ipd);
        head.timestamp_s = timestamp_s.unwrap_or(0.0);
        // A rotation that is no rotation (NaN after normalising) is a dropout.
        head.valid = orientation.is_finite() && position.is_finite();
        head
    }
}

/// What the DTrack source has seen.
#[derive(Resource, Clone, Debug, Default, PartialEq)]
pub struct DTrackStats {
    /// The address the socket is bound to (with the port the system gave
    /// for port 0), once bound.
    pub local_addr: Option<SocketAddr>,
    /// Datagrams parsed.
    pub frames: u64,
    /// Datagrams refused (the last reason in `last_error`).
    pub malformed: u64,
    /// Frames without the head's body (the head was reported lost).
    pub missing_body: u64,
    /// Why the last refused datagram was refused, or the socket could not
    /// be bound.
    pub last_error: Option<DTrackError>,
}

/// The bound socket (and what it was bound for).
#[derive(Resource)]
pub(crate) struct DTrackSocket {
    socket: UdpSocket,
    bind: SocketAddr,
}

/// Reads every datagram that came in and writes the head from the newest
/// frame (only when it changed).
pub(crate) fn read_dtrack(
    settings: &DTrackSettings,
    socket: &mut Option<ResMut<DTrackSocket>>,
    commands: &mut Commands,
    stats: &mut DTrackStats,
    head: &mut TrackedHead,
) -> bool {
    let Some(socket) = socket.as_deref().filter(|s| s.bind == settings.bind) else {
        match UdpSocket::bind(settings.bind).and_then(|s| s.set_nonblocking(true).map(|_| s)) {
            Ok(s) => {
                stats.local_addr = s.local_addr().ok();
                commands.insert_resource(DTrackSocket {
                    socket: s,
                    bind: settings.bind,
                });
            }
            Err(e) => {
                let why = DTrackError::Bind {
                    addr: settings.bind,
                    message: e.to_string(),
                };
                if stats.last_error.as_ref() != Some(&why) {
                    warn!("foveated LOD: DTrack {why}");
                    stats.last_error = Some(why);
                }
            }
        }
        return false;
    };
    let mut buf = [0u8; 65_536];
    let mut newest: Option<DTrackFrame> = None;
    for _ in 0..MAX_DATAGRAMS_PER_FRAME {
        let Ok(n) = socket.socket.recv(&mut buf) else {
            break;
        };
        match DTrackFrame::parse(&buf[..n]) {
            Ok(frame) => {
                stats.frames += 1;
                newest = Some(frame);
            }
            Err(e) => {
                stats.malformed += 1;
                stats.last_error = Some(e);
            }
        }
    }
    let Some(frame) = newest else {
        return false;
    };
    let next = match frame.bodies.iter().find(|b| b.id == settings.body) {
        Some(body) => settings.head_of(body, frame.timestamp_s),
        None => {
            stats.missing_body += 1;
            head.lost()
        }
    };
    if *head != next {
        *head = next;
        return true;
    }
    false
}
