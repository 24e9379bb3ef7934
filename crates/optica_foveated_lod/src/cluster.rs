//! A CAVE across processes: one process per wall (and per eye in stereo),
//! every one drawing frame `n` from head sample `n`, in lock step.
//!
//! One head source ([`HeadPublisher`], next to the tracker) publishes each
//! sample over UDP to every wall that joined; each wall process
//! ([`HeadSubscriber`], or [`CaveWallPlugin`] in a Bevy app) draws its
//! frame from that sample and answers that it did. The source publishes
//! sample `n + 1` only once every live wall has drawn `n` — a frame
//! barrier, so walls never show frames of different samples for longer
//! than a frame takes — or once [`HeadPublisher::wall_timeout`] has passed
//! (default [`WALL_TIMEOUT`]): a wall that died or hangs holds the others
//! back by at most that, once, and is dropped from the barrier. A wall that
//! joins late, or comes back, is sent the current sample at once and is in
//! the barrier from then on.
//!
//! Set [`Foveation::clock`](crate::Foveation::clock) to
//! [`FoveationClock::HeadSample`](crate::FoveationClock::HeadSample) in
//! every wall process, so that the level each object is drawn at is a
//! function of the samples alone and agrees across the walls' seams.
//!
//! ## The format
//!
//! A datagram is the four bytes `OPCV`, the protocol version
//! ([`PROTOCOL_VERSION`]), then one [`ClusterMessage`] in postcard's
//! serde encoding (its wire format is specified and stable since 1.0):
//!
//! | message | from | meaning |
//! |---|---|---|
//! | `Join { wall }` | wall | add me (sent again every [`JOIN_INTERVAL`] while no sample comes) |
//! | `Sample { n, head }` | source | draw frame `n` from [`TrackedHead`] `head` (sent again every [`HeadPublisher::resend`] to walls that have not answered) |
//! | `Drawn { n, wall }` | wall | frame `n` is drawn |
//! | `End` | source | the show is over |
//!
//! A datagram that is not one of these (another program's, a truncated
//! one, another version's) is counted and dropped, never a panic.
//!
//! The latency from a sample to the walls' frames drawn from it is
//! measured by the source: [`FrameReport::drawn`].
//!
//! ```no_run
//! use std::time::Duration;
//! use optica_foveated_lod::TrackedHead;
//! use optica_foveated_lod::cluster::{HeadPublisher, HeadSubscriber};
//!
//! // The head source.
//! let mut source = HeadPublisher::bind("0.0.0.0:7700")?;
//! source.wait_for_walls(3, Duration::from_secs(30));
//! for n in 0..600 {
//!     let report = source.publish(n, &TrackedHead::default());
//!     assert!(report.dropped.is_empty());
//! }
//! source.end();
//!
//! // A wall (another process, another machine).
//! let mut wall = HeadSubscriber::join("10.0.0.1:7700".parse()?, "front")?;
//! while let Some((n, head)) = wall.next_sample(Duration::from_secs(5))? {
//!     // ... draw frame n from `head` ...
//!     wall.drawn(n)?;
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::net::{SocketAddr, ToSocketAddrs, UdpSocket};
use std::time::{Duration, Instant};

use bevy::prelude::*;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::head::TrackedHead;

/// The first bytes of every datagram.
pub const MAGIC: [u8; 4] = *b"OPCV";

/// The protocol version this build speaks (the byte after [`MAGIC`]).
pub const PROTOCOL_VERSION: u8 = 1;

/// The largest datagram either side sends or reads (bytes).
pub const MAX_DATAGRAM: usize = 1024;

/// The longest wall name (bytes); longer names are cut.
pub const MAX_WALL_NAME: usize = 64;

/// How long a frame waits for a wall before dropping it from the barrier.
pub const WALL_TIMEOUT: Duration = Duration::from_millis(1000);

/// How often a wall waiting for its first sample says it is there.
pub const JOIN_INTERVAL: Duration = Duration::from_millis(200);

/// What crosses the network (see the module docs for the format).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum ClusterMessage {
    /// A wall asks to be sent the samples.
    Join {
        /// Its name, for reports (e.g. `front`, `right/left-eye`).
        wall: String,
    },
    /// Draw frame `n` from this head.
    Sample {
        /// The sample's number: the frame it is drawn in.
        n: u64,
        /// The head.
        head: TrackedHead,
    },
    /// A wall drew frame `n`.
    Drawn {
        /// The frame.
        n: u64,
        /// The wall's name.
        wall: String,
    },
    /// The show is over.
    End,
}

impl ClusterMessage {
    /// The datagram: [`MAGIC`], [`PROTOCOL_VERSION`], postcard.
    pub fn encode(&self) -> Vec<u8> {
        let mut bytes = Vec::with_capacity(64);
        bytes.extend_from_slice(&MAGIC);
        bytes.push(PROTOCOL_VERSION);
        // Serialising to a growing Vec fails only on out-of-memory.
        postcard::to_extend(self, bytes).expect("a cluster message serialises")
    }

    /// The message in a datagram, or why it is not one. A sample's head
    /// orientation is normalised; one that is zero or not finite makes the
    /// sample invalid (the dropout policy applies), as for the tracker
    /// sources.
    pub fn decode(bytes: &[u8]) -> Result<Self, ClusterError> {
        let rest = bytes.strip_prefix(&MAGIC).ok_or(ClusterError::NotOurs)?;
        let (&version, body) = rest.split_first().ok_or(ClusterError::NotOurs)?;
        if version != PROTOCOL_VERSION {
            return Err(ClusterError::Version(version));
        }
        let (message, trailing) = postcard::take_from_bytes::<Self>(body)
            .map_err(|e| ClusterError::Malformed(e.to_string()))?;
        if !trailing.is_empty() {
            return Err(ClusterError::Malformed(format!(
                "{} bytes after the message",
                trailing.len()
            )));
        }
        Ok(match message {
            Self::Sample { n, head } => Self::Sample {
                n,
                head: with_rotation(head),
            },
            other => other,
        })
    }
}

/// `head` with a unit orientation, or marked invalid where its orientation
/// is no rotation (zero, or not finite).
fn with_rotation(mut head: TrackedHead) -> TrackedHead {
    let q = Vec4::from(head.orientation);
    // Scaled by its largest component first: a quaternion of length 1e30
    // is a rotation too, though its squared length overflows.
    let largest = q.abs().max_element();
    if !(q.is_finite() && largest > 0.0) {
        head.valid = false;
        return head;
    }
    let unit = (q / largest).normalize();
    // A unit quaternion is passed on bit for bit: every wall decodes the
    // same head the source sent.
    if (q.length() - 1.0).abs() > 1e-6 {
        head.orientation = Quat::from_vec4(unit);
    }
    head
}

/// Why a datagram was refused or the cluster could not go on.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum ClusterError {
    /// Not a CAVE datagram (no `OPCV` header).
    #[error("not an optica CAVE datagram (no OPCV header)")]
    NotOurs,
    /// Another protocol version.
    #[error("protocol version {0}; this build speaks {PROTOCOL_VERSION}")]
    Version(u8),
    /// The header is right but the message is not.
    #[error("malformed CAVE datagram: {0}")]
    Malformed(String),
    /// A socket that could not be bound or used.
    #[error("CAVE socket: {0}")]
    Socket(String),
    /// No sample came within the time given.
    #[error("no head sample from {from} within {waited_ms} ms")]
    Timeout {
        /// The head source.
        from: SocketAddr,
        /// How long the wall waited (ms).
        waited_ms: u128,
    },
}

fn socket_error(e: std::io::Error) -> ClusterError {
    ClusterError::Socket(e.to_string())
}

fn wall_name(name: impl Into<String>) -> String {
    let mut name: String = name.into();
    if name.len() > MAX_WALL_NAME {
        let mut cut = MAX_WALL_NAME;
        while !name.is_char_boundary(cut) {
            cut -= 1;
        }
        name.truncate(cut);
    }
    name
}

/// Receives one datagram within `wait` (`None` when none came).
fn receive(socket: &UdpSocket, wait: Duration) -> Option<(Vec<u8>, SocketAddr)> {
    // A zero read timeout means "block forever" to the OS.
    socket
        .set_read_timeout(Some(wait.max(Duration::from_micros(100))))
        .ok()?;
    let mut buffer = [0u8; MAX_DATAGRAM];
    let (len, from) = socket.recv_from(&mut buffer).ok()?;
    Some((buffer[..len].to_vec(), from))
}

/// A wall as the head source sees it.
#[derive(Clone, Debug)]
struct WallPeer {
    name: String,
    addr: SocketAddr,
    /// The newest frame it said it drew.
    drawn: Option<u64>,
    /// In the barrier (it answered in time, or joined since).
    live: bool,
}

/// What happened to one published sample.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameReport {
    /// The sample (frame) number.
    pub n: u64,
    /// Each wall that drew the frame, with the time from sending the
    /// sample to its answer: the latency from a head sample to that wall's
    /// new frame.
    pub drawn: Vec<(String, Duration)>,
    /// Walls dropped from the barrier in this frame (no answer within
    /// [`HeadPublisher::wall_timeout`]).
    pub dropped: Vec<String>,
    /// Walls that joined (or came back) during this frame.
    pub joined: Vec<String>,
}

/// The head source: publishes each sample to every wall and holds the next
/// until they drew it (or timed out). Not a Bevy type: run it next to the
/// tracker, in its own process or thread.
pub struct HeadPublisher {
    socket: UdpSocket,
    walls: Vec<WallPeer>,
    /// How long a frame waits for a wall's answer before dropping it.
    pub wall_timeout: Duration,
    /// How often a sample is sent again to walls that have not answered
    /// (UDP may lose it).
    pub resend: Duration,
    /// Datagrams refused (not ours, another version, malformed).
    pub refused: u64,
}

impl HeadPublisher {
    /// Binds the source's socket (`"0.0.0.0:7700"`; port 0 picks a free
    /// one, see [`local_addr`](Self::local_addr)).
    pub fn bind(addr: impl ToSocketAddrs) -> Result<Self, ClusterError> {
        let socket = UdpSocket::bind(addr).map_err(socket_error)?;
        Ok(Self {
            socket,
            walls: Vec::new(),
            wall_timeout: WALL_TIMEOUT,
            resend: Duration::from_millis(50),
            refused: 0,
        })
    }

    /// The address walls join.
    pub fn local_addr(&self) -> Result<SocketAddr, ClusterError> {
        self.socket.local_addr().map_err(socket_error)
    }

    /// The walls that joined, with whether each is in the barrier.
    pub fn walls(&self) -> impl Iterator<Item = (&str, bool)> {
        self.walls.iter().map(|w| (w.name.as_str(), w.live))
    }

    /// Waits until `count` walls have joined or `timeout` passed; returns
    /// how many joined.
    pub fn wait_for_walls(&mut self, count: usize, timeout: Duration) -> usize {
        let start = Instant::now();
        while self.live_walls() < count {
            let Some(left) = timeout.checked_sub(start.elapsed()) else {
                break;
            };
            if let Some((bytes, from)) = receive(&self.socket, left) {
                self.take(&bytes, from, None, &mut FrameReport::default(), start);
            }
        }
        self.live_walls()
    }

    fn live_walls(&self) -> usize {
        self.walls.iter().filter(|w| w.live).count()
    }

    fn send(&self, message: &[u8], to: SocketAddr) {
        // A send that fails (the wall's port closed) is a wall that does
        // not answer: the timeout deals with it.
        let _ = self.socket.send_to(message, to);
    }

    /// Handles one datagram during frame `n` (`None` before the first).
    fn take(
        &mut self,
        bytes: &[u8],
        from: SocketAddr,
        sample: Option<(u64, &[u8])>,
        report: &mut FrameReport,
        sent: Instant,
    ) {
        let message = match ClusterMessage::decode(bytes) {
            Ok(m) => m,
            Err(_) => {
                self.refused += 1;
                return;
            }
        };
        match message {
            ClusterMessage::Join { wall } => {
                let wall = wall_name(wall);
                let peer = match self.walls.iter_mut().position(|w| w.addr == from) {
                    Some(i) if self.walls[i].live => return,
                    Some(i) => &mut self.walls[i],
                    None => {
                        self.walls.push(WallPeer {
                            name: wall.clone(),
                            addr: from,
                            drawn: None,
                            live: false,
                        });
                        self.walls.last_mut().expect("just pushed")
                    }
                };
                peer.live = true;
                peer.name = wall.clone();
                report.joined.push(wall);
                // A late wall gets the current sample at once.
                if let Some((_, datagram)) = sample {
                    self.send(datagram, from);
                }
            }
            ClusterMessage::Drawn { n, .. } => {
                let Some(peer) = self.walls.iter_mut().find(|w| w.addr == from) else {
                    return;
                };
                let first = peer.drawn.is_none_or(|d| d < n);
                peer.drawn = Some(peer.drawn.map_or(n, |d| d.max(n)));
                let back = !peer.live;
                if first && sample.is_some_and(|(current, _)| current == n) {
                    report.drawn.push((peer.name.clone(), sent.elapsed()));
                }
                if back {
                    // A dropped wall that answers is back, and is sent the
                    // sample under way.
                    peer.live = true;
                    report.joined.push(peer.name.clone());
                    if let Some((current, datagram)) = sample
                        && n < current
                    {
                        self.send(datagram, from);
                    }
                }
            }
            ClusterMessage::Sample { .. } | ClusterMessage::End => self.refused += 1,
        }
    }

    /// Publishes sample `n` to every live wall and waits until each drew
    /// it, or [`wall_timeout`](Self::wall_timeout) passed (those walls are
    /// dropped from the barrier). Walls that join meanwhile are sent it too.
    pub fn publish(&mut self, n: u64, head: &TrackedHead) -> FrameReport {
        let datagram = ClusterMessage::Sample {
            n,
            head: head.clone(),
        }
        .encode();
        let mut report = FrameReport { n, ..default() };
        let sent = Instant::now();
        let mut last_send = sent;
        for wall in self.walls.iter().filter(|w| w.live) {
            self.send(&datagram, wall.addr);
        }
        loop {
            let waiting: Vec<SocketAddr> = self
                .walls
                .iter()
                .filter(|w| w.live && w.drawn.is_none_or(|d| d < n))
                .map(|w| w.addr)
                .collect();
            if waiting.is_empty() {
                break;
            }
            let Some(left) = self.wall_timeout.checked_sub(sent.elapsed()) else {
                for wall in self.walls.iter_mut().filter(|w| waiting.contains(&w.addr)) {
                    wall.live = false;
                    report.dropped.push(wall.name.clone());
                }
                break;
            };
            if last_send.elapsed() >= self.resend {
                for &addr in &waiting {
                    self.send(&datagram, addr);
                }
                last_send = Instant::now();
            }
            let wait = left.min(self.resend.saturating_sub(last_send.elapsed()));
            if let Some((bytes, from)) = receive(&self.socket, wait) {
                self.take(&bytes, from, Some((n, &datagram)), &mut report, sent);
            }
        }
        report
    }

    /// Tells every wall the show is over.
    pub fn end(&mut self) {
        let datagram = ClusterMessage::End.encode();
        for wall in &self.walls {
            self.send(&datagram, wall.addr);
        }
    }
}

/// A wall's end of the stream: joins the source, takes each new sample,
/// answers when its frame is drawn.
pub struct HeadSubscriber {
    socket: UdpSocket,
    source: SocketAddr,
    wall: String,
    last: Option<u64>,
    /// Datagrams refused (not ours, another version, malformed, or not
    /// from the source).
    pub refused: u64,
}

impl HeadSubscriber {
    /// Binds a socket of its own (any free port) and asks `source` for the
    /// samples as `wall`.
    pub fn join(source: SocketAddr, wall: impl Into<String>) -> Result<Self, ClusterError> {
        let any: SocketAddr = if source.is_ipv4() {
            ([0, 0, 0, 0], 0).into()
        } else {
            (std::net::Ipv6Addr::UNSPECIFIED, 0).into()
        };
        let socket = UdpSocket::bind(any).map_err(socket_error)?;
        let subscriber = Self {
            socket,
            source,
            wall: wall_name(wall),
            last: None,
            refused: 0,
        };
        subscriber.say_join()?;
        Ok(subscriber)
    }

    fn say_join(&self) -> Result<(), ClusterError> {
        let join = ClusterMessage::Join {
            wall: self.wall.clone(),
        };
        self.socket
            .send_to(&join.encode(), self.source)
            .map(|_| ())
            .map_err(socket_error)
    }

    /// The newest sample drawn (answered) so far.
    pub fn last(&self) -> Option<u64> {
        self.last
    }

    /// Waits for the next sample: `Some((n, head))`, `None` when the source
    /// ended the show, or [`ClusterError::Timeout`] after `timeout` without
    /// one. A sample already taken (sent again because the answer was lost)
    /// is answered again and skipped.
    pub fn next_sample(
        &mut self,
        timeout: Duration,
    ) -> Result<Option<(u64, TrackedHead)>, ClusterError> {
        let start = Instant::now();
        let mut last_join = start;
        loop {
            let Some(left) = timeout.checked_sub(start.elapsed()) else {
                return Err(ClusterError::Timeout {
                    from: self.source,
                    waited_ms: timeout.as_millis(),
                });
            };
            if self.last.is_none() && last_join.elapsed() >= JOIN_INTERVAL {
                self.say_join()?;
                last_join = Instant::now();
            }
            let Some((bytes, from)) = receive(&self.socket, left.min(JOIN_INTERVAL)) else {
                continue;
            };
            if from != self.source {
                self.refused += 1;
                continue;
            }
            match ClusterMessage::decode(&bytes) {
                Ok(ClusterMessage::Sample { n, head }) => {
                    if self.last.is_some_and(|last| n <= last) {
                        if self.last == Some(n) {
                            self.drawn(n)?;
                        }
                        continue;
                    }
                    self.last = Some(n);
                    return Ok(Some((n, head)));
                }
                Ok(ClusterMessage::End) => return Ok(None),
                Ok(_) | Err(_) => self.refused += 1,
            }
        }
    }

    /// Says frame `n` is drawn.
    pub fn drawn(&self, n: u64) -> Result<(), ClusterError> {
        let message = ClusterMessage::Drawn {
            n,
            wall: self.wall.clone(),
        };
        self.socket
            .send_to(&message.encode(), self.source)
            .map(|_| ())
            .map_err(socket_error)
    }
}

/// Makes a Bevy app one wall of a CAVE across processes: at the start of
/// each update it answers that the previous frame is drawn, waits for the
/// next sample (up to [`CaveWallPlugin::timeout`]) and writes it to
/// [`TrackedHead`]. Use it with [`HeadSource::External`](crate::HeadSource::External)
/// (the default) and [`FoveationClock::HeadSample`](crate::FoveationClock::HeadSample).
/// When the source ends the show the app exits; when no sample comes in
/// time the wall keeps its last head and waits again next update (logged).
pub struct CaveWallPlugin {
    /// The head source's address.
    pub source: SocketAddr,
    /// This wall's name (e.g. `front`, `right/left-eye`).
    pub wall: String,
    /// How long an update waits for a sample.
    pub timeout: Duration,
}

/// The wall's subscriber and the frame it owes an answer for.
#[derive(Resource)]
pub struct CaveWall {
    subscriber: HeadSubscriber,
    owed: Option<u64>,
    timeout: Duration,
    /// The sample the current frame is drawn from.
    pub sample: Option<u64>,
}

impl Plugin for CaveWallPlugin {
    fn build(&self, app: &mut App) {
        match HeadSubscriber::join(self.source, self.wall.clone()) {
            Ok(subscriber) => {
                app.insert_resource(CaveWall {
                    subscriber,
                    owed: None,
                    timeout: self.timeout,
                    sample: None,
                })
                .add_systems(First, take_sample);
            }
            Err(e) => error!(
                "optica CAVE wall {}: {e}; the wall is not joined",
                self.wall
            ),
        }
    }
}

fn take_sample(
    mut wall: ResMut<CaveWall>,
    mut head: ResMut<TrackedHead>,
    mut exit: MessageWriter<AppExit>,
) {
    let wall = &mut *wall;
    if let Some(n) = wall.owed.take()
        && let Err(e) = wall.subscriber.drawn(n)
    {
        warn!("optica CAVE wall: {e}");
    }
    match wall.subscriber.next_sample(wall.timeout) {
        Ok(Some((n, sample))) => {
            *head = sample;
            wall.owed = Some(n);
            wall.sample = Some(n);
        }
        Ok(None) => {
            exit.write(AppExit::Success);
        }
        Err(e) => warn!("optica CAVE wall: {e}; keeping the last head"),
    }
}
