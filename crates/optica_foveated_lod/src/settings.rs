//! What users edit: the visual field and the switching policy
//! ([`Foveation`]), and the checked form the systems use.

use bevy::prelude::*;
use optica_optics::foveated_lod::{
    BoundaryShape, FieldExtents, FoveatedError, HysteresisParams, VisualField,
};

use crate::head::{Eye, eye_model};

/// Whose visual field decides the level.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Reflect)]
pub enum FieldEyes {
    /// One eye between the two, the paper's model: its m_α is unsigned, so
    /// the ear-side extent applies to both sides.
    #[default]
    Cyclopean,
    /// Each eye its own field (ear side out, nose side in); an object's level
    /// is the larger of the two eyes' levels, and a CAVE wall camera of one
    /// eye uses that eye's field.
    PerEye,
}

/// The shape of the peripheral boundary (eq. 7).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Reflect)]
pub enum FieldBoundary {
    /// Eq. 7 as printed: L(φ) = √(a²cos²φ + b²sin²φ).
    #[default]
    PaperEq7,
    /// A true ellipse with the same semi-axes.
    TrueEllipse,
}

/// The foveation settings: the visual field (eq. 1–8 of Mochizuki and
/// Makino), how the tracker's dropouts are handled, and how levels are
/// quantised and held against flicker.
///
/// The defaults are the paper's field (central 30°, 100° to the ear side,
/// 60° up, 70° down), eight level steps with a dead band of 0.05 and a
/// quarter-second dwell before detail is taken away, and a gaze held for
/// 0.2 s through a tracker dropout; the mesh path foveates while that saves
/// at least a fifth of the triangles. Invalid settings (an extent outside
/// `central..=180°`, a dead band of a whole step) are logged once and the
/// defaults used instead.
#[derive(Resource, Clone, Debug, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct Foveation {
    /// Off: every level is 1 (full quality), as if no gaze were known.
    pub enabled: bool,
    /// Radius of the central field, where the level is 1 (degrees).
    pub central_deg: f32,
    /// Extent to the ear side (degrees).
    pub ear_deg: f32,
    /// Extent to the nose side (degrees; only [`FieldEyes::PerEye`] uses it).
    pub nose_deg: f32,
    /// Extent upwards (degrees).
    pub upper_deg: f32,
    /// Extent downwards (degrees).
    pub lower_deg: f32,
    /// One cyclopean field or one per eye.
    pub eyes: FieldEyes,
    /// The boundary's shape.
    pub boundary: FieldBoundary,
    /// Level steps S: levels are k/S, k = 0..=S. A level is rounded down to
    /// its step, ⌊S·level⌋/S (never more detail than eq. 8 asks), and eq. 10's
    /// polygon budget and eq. 9's bounces are taken at the rounded level.
    pub steps: u32,
    /// A level must pass a step edge by this much (level units, < 1/S)
    /// before an object switches.
    pub dead_band: f32,
    /// An object keeps a finer level at least this long before it is made
    /// coarser (s); finer levels are taken at once.
    pub min_dwell_s: f32,
    /// How long the last valid gaze is kept through a tracker dropout
    /// before everything is drawn at full quality (s).
    pub hold_timeout_s: f32,
    /// The mesh path draws coarser meshes only while they save at least
    /// this fraction of the [`GazeLod`](crate::GazeLod) objects' triangles
    /// (see [`FoveationGate`](crate::FoveationGate)); 0 always foveates.
    pub min_saving: f32,
}

impl Default for Foveation {
    fn default() -> Self {
        let e = FieldExtents::PAPER;
        let h = HysteresisParams::default();
        Self {
            enabled: true,
            central_deg: e.central.to_degrees() as f32,
            ear_deg: e.ear.to_degrees() as f32,
            nose_deg: e.nose.to_degrees() as f32,
            upper_deg: e.upper.to_degrees() as f32,
            lower_deg: e.lower.to_degrees() as f32,
            eyes: FieldEyes::Cyclopean,
            boundary: FieldBoundary::PaperEq7,
            steps: h.steps(),
            dead_band: h.dead_band() as f32,
            min_dwell_s: h.min_dwell_s() as f32,
            hold_timeout_s: 0.2,
            min_saving: 0.2,
        }
    }
}

/// [`Foveation`] checked: what the systems use.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct CheckedFoveation {
    /// Foveation on.
    pub enabled: bool,
    /// The field model.
    pub eyes: FieldEyes,
    /// Left, right and cyclopean fields.
    pub fields: [VisualField; 3],
    /// Level steps, dead band and dwell.
    pub hysteresis: HysteresisParams,
    /// The dropout hold (s), finite and ≥ 0.
    pub hold_timeout_s: f32,
    /// The mesh path's saving threshold, in [0, 1].
    pub min_saving: f32,
}

impl Default for CheckedFoveation {
    fn default() -> Self {
        Foveation::default()
            .check()
            .expect("the default foveation settings are valid")
    }
}

impl CheckedFoveation {
    /// The field of `eye`.
    pub fn field(&self, eye: Eye) -> VisualField {
        self.fields[crate::head::eye_index(eye)]
    }
}

impl Foveation {
    /// The settings checked, or the first one out of range.
    pub fn check(&self) -> Result<CheckedFoveation, FoveatedError> {
        let extents = FieldExtents {
            central: (self.central_deg as f64).to_radians(),
            ear: (self.ear_deg as f64).to_radians(),
            nose: (self.nose_deg as f64).to_radians(),
            upper: (self.upper_deg as f64).to_radians(),
            lower: (self.lower_deg as f64).to_radians(),
        };
        let boundary = match self.boundary {
            FieldBoundary::PaperEq7 => BoundaryShape::PaperEq7,
            FieldBoundary::TrueEllipse => BoundaryShape::TrueEllipse,
        };
        let field = |eye| VisualField::new(extents, eye_model(self.eyes, eye), boundary);
        let fields = [
            field(Eye::Left)?,
            field(Eye::Right)?,
            field(Eye::Cyclopean)?,
        ];
        let hysteresis =
            HysteresisParams::new(self.steps, self.dead_band as f64, self.min_dwell_s as f64)?;
        let hold_timeout_s = optica_optics::input::non_negative(
            "gaze hold timeout (s)",
            self.hold_timeout_s as f64,
        )? as f32;
        let min_saving = optica_optics::input::in_range(
            "minimum triangle saving",
            self.min_saving as f64,
            0.0,
            1.0,
        )? as f32;
        Ok(CheckedFoveation {
            min_saving,
            enabled: self.enabled,
            eyes: self.eyes,
            fields,
            hysteresis,
            hold_timeout_s,
        })
    }
}

/// Checks [`Foveation`] when it changes; invalid settings are logged once and
/// the defaults used.
pub(crate) fn check_foveation(foveation: Res<Foveation>, mut checked: ResMut<CheckedFoveation>) {
    if !foveation.is_changed() {
        return;
    }
    let next = foveation.check().unwrap_or_else(|e| {
        warn!("foveated LOD: {e}; using the default foveation settings");
        CheckedFoveation::default()
    });
    checked.set_if_neq(next);
}
