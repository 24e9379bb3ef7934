//! The user-facing dome camera component.

use bevy::prelude::*;
use optica_optics::dome::{DomeError, DomeProjection, DomeSettings};

/// A fisheye dome camera: add it to a `Camera3d` and the camera renders an
/// equidistant (f-θ) domemaster — a square image with the inscribed image
/// circle, the zenith (dome axis) at the centre and the audience front at
/// the bottom.
///
/// Mount the camera like a fisheye pointing at the zenith: its −Z is the
/// dome axis at `tilt_deg = 0`, its +Y the image's up, so the audience front
/// is the camera's −Y. The plugin replaces the camera's `Projection` and
/// keeps it in step with this component.
///
/// ```no_run
/// use bevy::prelude::*;
/// use optica_dome::{DomeCamera, DomePlugin};
///
/// fn setup(mut commands: Commands) {
///     commands.spawn((
///         // Looking up, the theatre's back towards +Z.
///         Transform::from_xyz(0.0, 1.6, 0.0).looking_to(Vec3::Y, Vec3::Z),
///         DomeCamera { fov_deg: 180.0, ..default() },
///     ));
/// }
/// # App::new().add_plugins((DefaultPlugins, DomePlugin)).add_systems(Startup, setup);
/// ```
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Component, Default)]
#[require(Camera3d)]
pub struct DomeCamera {
    /// Full field of view in degrees: 180 is the standard dome, 210–250 are
    /// wide fisheyes. Valid: `(0, 350]`.
    pub fov_deg: f32,
    /// Forward tilt of the dome axis in degrees (tilted domes: 10–30).
    pub tilt_deg: f32,
    /// How far, in domemaster pixels, a drawn edge may lie from the true
    /// curved image of the 3D edge: triangles are split until their edges'
    /// chords are within it (the paper's refinement). Smaller is more
    /// exact and costs more triangles.
    pub tolerance_px: f32,
    /// Nearest distance drawn, in world units.
    pub near: f32,
    /// Farthest distance culling and shadows consider, in world units.
    pub far: f32,
    /// How the domemaster is made: by projecting vertices (the paper) or by
    /// resampling a cube of ordinary cameras.
    pub mode: DomeMode,
}

/// How a [`DomeCamera`] makes its image.
#[derive(Reflect, Clone, Copy, Debug, PartialEq, Default)]
pub enum DomeMode {
    /// The paper's method: every vertex projected equidistantly, triangles
    /// refined on the CPU to [`DomeCamera::tolerance_px`]. Ordinary lit
    /// meshes and materials whose vertex shader goes through Bevy's
    /// `view_transformations`; the cheaper mode at equal error.
    #[default]
    Vertex,
    /// The scene drawn by 4, 5 or 6 perspective cameras (by field of view:
    /// ≤ 180°, ≤ 250°, wider), each into a square image of `face_px`,
    /// resampled into the domemaster. Works with any material and any
    /// screen-space effect of the faces; costs one scene draw per face.
    /// The faces see render layer 0 only.
    CubeMap {
        /// Side of each face image in pixels, `[8, 16384]`. About 0.64× the
        /// domemaster's size matches its pixels at the zenith of a 180°
        /// dome.
        face_px: u32,
    },
}

/// The face sizes the cube mode accepts.
pub const FACE_PX_RANGE: std::ops::RangeInclusive<u32> = 8..=16384;

/// The widest field of view the vertex projection accepts: beyond it the
/// antipode, where the projection is singular, comes within 5° of the rim.
pub const MAX_FOV_DEG: f32 = 350.0;

impl Default for DomeCamera {
    /// A 180° untilted dome, edges within 0.5 px of their true image,
    /// drawing from 0.1 to 1000 units.
    fn default() -> Self {
        Self {
            fov_deg: 180.0,
            tilt_deg: 0.0,
            tolerance_px: 0.5,
            near: 0.1,
            far: 1000.0,
            mode: DomeMode::Vertex,
        }
    }
}

impl DomeCamera {
    /// The CPU twin's projection for a domemaster of `size_px`, the
    /// reference the plugin's shaders are tested against. Errors for a
    /// field of view or tilt the projection cannot take.
    pub fn projection(&self, size_px: u32) -> Result<DomeProjection, DomeError> {
        DomeProjection::new(&DomeSettings {
            fov_deg: f64::from(self.fov_deg),
            tilt_deg: f64::from(self.tilt_deg),
            size_px,
        })
    }

    /// Checks every number; the first one that is wrong, in words.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.fov_deg > 0.0 && self.fov_deg <= MAX_FOV_DEG) {
            return Err(format!(
                "dome field of view {} deg is outside (0, {MAX_FOV_DEG}]",
                self.fov_deg
            ));
        }
        if !self.tilt_deg.is_finite() {
            return Err(format!("dome tilt {} deg is not finite", self.tilt_deg));
        }
        if !(self.tolerance_px > 0.0 && self.tolerance_px.is_finite()) {
            return Err(format!(
                "dome tolerance {} px is not positive",
                self.tolerance_px
            ));
        }
        if !(self.near > 0.0 && self.near.is_finite()) {
            return Err(format!("dome near distance {} is not positive", self.near));
        }
        if !(self.far > self.near && self.far.is_finite()) {
            return Err(format!(
                "dome far distance {} is not beyond near ({})",
                self.far, self.near
            ));
        }
        if let DomeMode::CubeMap { face_px } = self.mode
            && !FACE_PX_RANGE.contains(&face_px)
        {
            return Err(format!(
                "dome cube face size {face_px} px is outside {}..={}",
                FACE_PX_RANGE.start(),
                FACE_PX_RANGE.end()
            ));
        }
        Ok(())
    }
}
