//! What each fuzz target checks of one input, shared by the cargo-fuzz
//! targets (`fuzz_targets/*.rs`, libFuzzer on nightly) and the corpus
//! replay that CI runs on stable (`tests/render/fuzz_corpus.rs` includes
//! this file).
//!
//! Every format a user can hand the project: a `.lens` prescription (the
//! bytes the asset loader gets, through the checks the lens flare makes
//! before it traces), a head-trace CSV, a DTrack datagram, a dome
//! export's frame range, and a datagram of the CAVE cluster's head stream. For each input the outcome is a typed error that
//! says where (a line and a field where the format has them), or a value
//! that passes the plugin's own checks; a panic anywhere is a failure the
//! fuzzer reports. The time and memory caps per input are libFuzzer's
//! (`-timeout`, `-rss_limit_mb`, `-malloc_limit_mb`; see the README in
//! this folder) and the replay's.

use optica_dome::parse_frame_range;
use optica_foveated_lod::cluster::{ClusterMessage, MAX_DATAGRAM};
use optica_foveated_lod::dtrack::{DTrackFrame, DTrackSettings};
use optica_foveated_lod::{HeadTrace, TrackedHead};
use optica_optics::glam::DVec3;
use optica_optics::lens::{LensPrescription, PreparedLens, TracePath};
use optica_optics::lens_flare::{Aperture, Beam, EstimateOptions, estimate_ghost};

/// The lens flare's wavelengths: the band's ends and its middle (nm).
const WAVELENGTHS: [f64; 3] = [440.0, 550.0, 650.0];

/// A `.lens` file as the asset loader reads it. Accepted: a prescription
/// the flare can prepare at its wavelengths, whose paraxial data are
/// finite or refused, whose primary ray and first ghost trace or are
/// refused with an error.
pub fn lens(data: &[u8]) {
    let lens = match LensPrescription::parse_bytes(data) {
        Ok(lens) => lens,
        Err(e) => {
            assert!(!e.to_string().is_empty());
            return;
        }
    };
    assert!(
        !lens.surfaces().is_empty() && lens.surfaces().len() <= optica_optics::lens::MAX_SURFACES
    );
    if let Ok(p) = lens.paraxial(550.0) {
        assert!(
            p.efl_mm.is_finite() || p.efl_mm.is_infinite(),
            "paraxial EFL {}",
            p.efl_mm
        );
    }
    for wl in WAVELENGTHS {
        let Ok(prepared) = PreparedLens::new(&lens, wl) else {
            continue;
        };
        let light = DVec3::new(0.05, -0.03, 1.0);
        let aperture = Aperture::of_stop(&lens);
        let paths = [TracePath::Primary]
            .into_iter()
            .chain((lens.surfaces().len() >= 2).then(|| TracePath::ghost(1, 0)));
        for path in paths {
            let Ok(beam) = Beam::for_path(&lens, path, light, wl) else {
                continue;
            };
            if let Ok(ray) = beam.ray_at(0.5, 0.5)
                && let Ok(hit) = prepared.trace(ray, path)
            {
                assert!(
                    hit.throughput.is_finite() && hit.throughput >= 0.0,
                    "throughput {}",
                    hit.throughput
                );
            }
            let options = EstimateOptions {
                cells_per_side: 2,
                ..EstimateOptions::default()
            };
            if let TracePath::Ghost { .. } = path
                && let Ok(g) = estimate_ghost(&prepared, path, &beam, &aperture, &options)
            {
                assert!(
                    g.power.is_finite() && g.power >= 0.0,
                    "ghost power {}",
                    g.power
                );
                assert!(
                    g.intensity.is_finite() && g.intensity >= 0.0,
                    "ghost intensity {}",
                    g.intensity
                );
            }
        }
    }
}

/// The checks a head sample passes before it drives a view: a valid
/// sample has finite eyes and a unit orientation.
fn check_head(head: &TrackedHead) {
    if head.valid && head.eyes.iter().all(|e| e.is_finite()) {
        let q = head.orientation;
        assert!(
            !q.is_finite() || (q.length() - 1.0).abs() < 1e-3 || q.length() == 0.0,
            "orientation {q:?} is finite but not a rotation"
        );
    }
}

/// A head-trace CSV. Accepted: samples in time order with finite times,
/// looked up at any time, looping or not, without a panic, each sample
/// as above.
pub fn head_trace(data: &[u8]) {
    let trace = match HeadTrace::from_csv(data) {
        Ok(trace) => trace,
        Err(e) => {
            assert!(!e.to_string().is_empty());
            return;
        }
    };
    assert!(!trace.is_empty());
    let samples = trace.samples();
    assert!(
        samples
            .windows(2)
            .all(|w| w[0].timestamp_s <= w[1].timestamp_s)
    );
    assert!(samples.iter().all(|s| s.timestamp_s.is_finite()));
    samples.iter().for_each(check_head);
    let period = trace.period_s();
    assert!(period >= 0.0, "period {period}");
    for t in [
        0.0,
        0.5,
        trace.duration_s(),
        1e9,
        -1.0,
        f64::NAN,
        f64::INFINITY,
    ] {
        for looping in [false, true] {
            if let Some(head) = trace.at(t, looping) {
                check_head(head);
            }
        }
    }
}

/// A DTrack datagram. Accepted: at most `MAX_BODIES` bodies, each mapped
/// to a head that is a dropout or a usable sample.
pub fn dtrack(data: &[u8]) {
    let frame = match DTrackFrame::parse(data) {
        Ok(frame) => frame,
        Err(e) => {
            assert!(!e.to_string().is_empty());
            return;
        }
    };
    assert!(frame.bodies.len() <= optica_foveated_lod::dtrack::MAX_BODIES);
    if let Some(t) = frame.timestamp_s {
        assert!(t.is_finite());
    }
    let settings = DTrackSettings::default();
    for body in &frame.bodies {
        let head = settings.head_of(body, frame.timestamp_s);
        if head.valid {
            assert!(
                head.eyes.iter().all(|e| e.is_finite()),
                "valid head with eyes {:?}",
                head.eyes
            );
            assert!(head.orientation.is_finite());
        }
        check_head(&head);
    }
}

/// A dome export's frame range, as a farm manager writes it. Accepted: a
/// range that is not empty.
pub fn frame_range(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match parse_frame_range(text) {
        Ok(range) => assert!(!range.is_empty(), "{range:?}"),
        Err(e) => assert!(!e.to_string().is_empty()),
    }
}

/// A datagram of a multi-process CAVE's head stream, as a wall or the head
/// source reads it. Accepted: a message that encodes back to a datagram
/// that decodes to the same message (a sample's orientation, normalised
/// on decoding, within 1e-6); a sample's head as above.
pub fn cave_datagram(data: &[u8]) {
    // Neither side reads more than MAX_DATAGRAM bytes of a datagram.
    let data = &data[..data.len().min(MAX_DATAGRAM)];
    let message = match ClusterMessage::decode(data) {
        Ok(message) => message,
        Err(e) => {
            assert!(!e.to_string().is_empty());
            return;
        }
    };
    let again = ClusterMessage::decode(&message.encode()).expect("an encoded message decodes");
    match (&message, &again) {
        (ClusterMessage::Sample { n, head }, ClusterMessage::Sample { n: m, head: h }) => {
            assert_eq!(n, m);
            assert_eq!(head.valid, h.valid);
            if head.valid {
                assert!(head.orientation.abs_diff_eq(h.orientation, 1e-6));
            }
        }
        (a, b) => assert_eq!(a, b, "a message that does not survive encoding"),
    }
    match &message {
        ClusterMessage::Sample { head, .. } => check_head(head),
        ClusterMessage::Join { wall } | ClusterMessage::Drawn { wall, .. } => {
            assert!(
                wall.len() <= MAX_DATAGRAM,
                "a name longer than its datagram"
            );
        }
        ClusterMessage::End => {}
    }
}
