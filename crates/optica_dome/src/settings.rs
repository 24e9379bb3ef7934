//! The user-facing dome camera components: the [`DomeCamera`], the
//! layers it sees ([`DomeSees`]), how a mesh's apparent size is treated
//! ([`DomeApparentSize`]), and what became of it ([`DomeStatus`]).

use bevy::camera::visibility::RenderLayers;
use bevy::prelude::*;
use optica_optics::dome::{
    DomeError, DomeProjection, DomeSettings, EquirectProjection, EquirectSettings, FisheyeLens,
    Panorama,
};
use optica_optics::input;

use crate::Error;

/// A fisheye dome camera: add it to a `Camera3d` and the camera renders a
/// domemaster — the image circle inscribed in the target (fitted to its
/// shorter side when the target is not square), the zenith (dome axis) at
/// the centre and the audience front at the bottom. The lens is
/// equidistant (f-θ, the domemaster standard) unless [`DomeCamera::lens`]
/// says otherwise.
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
#[require(Camera3d, DomeStatus)]
pub struct DomeCamera {
    /// Full field of view in degrees: 180 is the standard dome, 210–250 are
    /// wide fisheyes. Valid: `(0, 350]`. Not used by
    /// [`DomeLens::Equirectangular`], which sees the whole sphere.
    pub fov_deg: f32,
    /// Forward tilt of the dome axis in degrees (tilted domes: 10–30).
    pub tilt_deg: f32,
    /// How far, in domemaster pixels, a drawn edge may lie from the true
    /// curved image of the 3D edge: triangles are split until their edges'
    /// chords are within it (the paper's refinement). Smaller is more
    /// exact and costs more triangles. Valid: at least
    /// [`MIN_TOLERANCE_PX`].
    pub tolerance_px: f32,
    /// Nearest distance drawn, in world units.
    pub near: f32,
    /// Farthest distance culling and shadows consider, in world units.
    pub far: f32,
    /// How the domemaster is made: by projecting vertices (the paper) or by
    /// resampling a cube of ordinary cameras.
    pub mode: DomeMode,
    /// How directions map to the image: a fisheye's radial mapping
    /// (equidistant by default), or the equirectangular panorama.
    pub lens: DomeLens,
    /// Vertex mode: give every fragment the texture coordinates, normal
    /// and colour of the point its own ray meets, instead of the values the
    /// rasteriser interpolates across each refined triangle's image (which
    /// put texture up to pixels from its place). On by default; off saves
    /// its per-fragment cost (see the `dome` report's textured room) where
    /// a scene has no texture to show it. Edges are placed by
    /// [`Self::tolerance_px`] either way.
    pub exact_attributes: bool,
}

/// The projection of a [`DomeCamera`]. The fisheyes are radial: a
/// direction at angle θ from the dome axis lands at radius `r = f·g(θ)`
/// from the image centre, with f set so that the rim (θ = FOV/2) lies on
/// the image circle. [`DomeLens::Equirectangular`] is the longitude–latitude
/// panorama of the whole sphere.
#[derive(Reflect, Clone, Copy, Debug, PartialEq, Default)]
pub enum DomeLens {
    /// g = θ: equal angles, equal radii. The domemaster standard.
    #[default]
    Equidistant,
    /// g = 2 sin(θ/2): equal solid angles cover equal areas (most
    /// photographic fisheyes).
    Equisolid,
    /// g = 2 tan(θ/2): conformal, shapes kept, stretched towards the rim.
    Stereographic,
    /// g = sin θ: a hemisphere seen from afar. At most 180°.
    Orthographic,
    /// g = k₁θ + k₂θ³ + k₃θ⁵ + k₄θ⁷, the Kannala–Brandt model calibration
    /// tools (OpenCV's `fisheye`, Kalibr) fit to real lenses: paste their
    /// coefficients and set the field of view the lens covers. k₁ > 0, and
    /// r must rise over the whole field of view.
    Polynomial {
        /// k₁ … k₄.
        k: [f32; 4],
    },
    /// Not a fisheye: longitude across (360°, the camera's −Z at the
    /// centre, its +X a quarter of the width to the right), latitude up
    /// (180°, the camera's +Y along the top row), filling the target (make
    /// it 2:1 for square pixels). `fov_deg` is not used; `tilt_deg` pitches
    /// the image centre down. Triangles and lines crossing the ±180° seam
    /// are split at it, and those over a pole fill the pole's row. Vertex
    /// mode meshes marked [`crate::DomeApparentSize::NearlyConstant`] are
    /// refined from the view like any other (the seam depends on it).
    Equirectangular,
}

impl DomeLens {
    /// The fisheyes (the polynomial with a mildly barrelled example lens).
    pub const FISHEYES: [DomeLens; 5] = [
        DomeLens::Equidistant,
        DomeLens::Equisolid,
        DomeLens::Stereographic,
        DomeLens::Orthographic,
        DomeLens::Polynomial {
            k: [1.0, -0.04, 0.003, -0.0001],
        },
    ];

    /// Every projection, for menus: the fisheyes and the equirectangular
    /// panorama.
    pub const ALL: [DomeLens; 6] = {
        let f = Self::FISHEYES;
        [f[0], f[1], f[2], f[3], f[4], DomeLens::Equirectangular]
    };

    /// The lens's name.
    pub fn name(&self) -> &'static str {
        match self {
            DomeLens::Equidistant => "equidistant",
            DomeLens::Equisolid => "equisolid",
            DomeLens::Stereographic => "stereographic",
            DomeLens::Orthographic => "orthographic",
            DomeLens::Polynomial { .. } => "polynomial",
            DomeLens::Equirectangular => "equirectangular",
        }
    }

    /// The CPU twin's lens; `None` for the equirectangular panorama.
    pub fn fisheye(&self) -> Option<FisheyeLens> {
        Some(match *self {
            DomeLens::Equidistant => FisheyeLens::Equidistant,
            DomeLens::Equisolid => FisheyeLens::Equisolid,
            DomeLens::Stereographic => FisheyeLens::Stereographic,
            DomeLens::Orthographic => FisheyeLens::Orthographic,
            DomeLens::Polynomial { k } => FisheyeLens::Polynomial {
                k: k.map(f64::from),
            },
            DomeLens::Equirectangular => return None,
        })
    }
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

/// The finest [`DomeCamera::tolerance_px`] accepted: 0.01 px, a hundredth
/// of a pixel, already far below what a rasteriser resolves. The
/// triangles grow as the inverse of the tolerance: a 90° triangle on a
/// 64 px dome is 1,130 triangles at 0.01 px, 6.5 million at 10⁻⁶ px (a
/// minute to refine, gigabytes for a room); found by drawing random
/// accepted settings.
pub const MIN_TOLERANCE_PX: f32 = 0.01;

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
            lens: DomeLens::Equidistant,
            exact_attributes: true,
        }
    }
}

impl DomeCamera {
    /// The CPU twin's fisheye projection for a square domemaster of
    /// `size_px`, the reference the plugin's shaders are tested against.
    /// Errors for a field of view, tilt or lens the projection cannot take,
    /// and [`DomeError::NotAFisheye`] for the equirectangular panorama (see
    /// [`Self::panorama`]).
    pub fn projection(&self, size_px: u32) -> Result<DomeProjection, DomeError> {
        self.projection_of_target(size_px, size_px)
    }

    /// [`Self::projection`] for a target of `width` × `height` pixels (the
    /// image circle fits the shorter side).
    pub fn projection_of_target(
        &self,
        width: u32,
        height: u32,
    ) -> Result<DomeProjection, DomeError> {
        DomeProjection::new(&DomeSettings {
            fov_deg: f64::from(self.fov_deg),
            tilt_deg: f64::from(self.tilt_deg),
            size_px: width,
            height_px: Some(height),
            lens: self.lens.fisheye().ok_or(DomeError::NotAFisheye)?,
        })
    }

    /// The CPU twin of any projection, fisheye or equirectangular, for a
    /// target of `width` × `height` pixels.
    pub fn panorama(&self, width: u32, height: u32) -> Result<Panorama, DomeError> {
        if self.lens == DomeLens::Equirectangular {
            let settings = EquirectSettings {
                width_px: width,
                height_px: Some(height),
                tilt_deg: f64::from(self.tilt_deg),
            };
            return Ok(Panorama::Equirectangular(EquirectProjection::new(
                &settings,
            )?));
        }
        Ok(Panorama::Fisheye(self.projection_of_target(width, height)?))
    }

    /// Checks every number and the lens against the field of view; the
    /// first refusal, naming what was wrong.
    pub fn validate(&self) -> Result<(), Error> {
        self.validate_numbers()?;
        // The lens against the field of view (an orthographic lens beyond
        // 180°, a polynomial that folds back): the CPU twin's own checks.
        self.panorama(256, 256)
            .map(|_| ())
            .map_err(|source| Error::Lens {
                lens: self.lens.name(),
                source,
            })
    }

    /// [`Self::validate`] but for the lens, which building the CPU twin
    /// ([`Self::panorama`]) checks: for callers that build it anyway, so
    /// that it is not built twice a frame.
    pub(crate) fn validate_numbers(&self) -> Result<(), Error> {
        let fisheye = self.lens != DomeLens::Equirectangular;
        if fisheye {
            // (0, MAX]: zero is no view at all.
            input::positive("field of view (deg)", f64::from(self.fov_deg))?;
            input::in_range(
                "field of view (deg)",
                f64::from(self.fov_deg),
                0.0,
                f64::from(MAX_FOV_DEG),
            )?;
        }
        input::finite("tilt (deg)", f64::from(self.tilt_deg))?;
        input::in_range(
            "tolerance (px)",
            f64::from(self.tolerance_px),
            f64::from(MIN_TOLERANCE_PX),
            f64::INFINITY,
        )?;
        input::positive("near distance", f64::from(self.near))?;
        input::finite("far distance", f64::from(self.far))?;
        if self.far <= self.near {
            return Err(Error::FarNotBeyondNear {
                far: self.far,
                near: self.near,
            });
        }
        if let DomeMode::CubeMap { face_px } = self.mode {
            input::in_range(
                "cube face size (px)",
                f64::from(face_px),
                f64::from(*FACE_PX_RANGE.start()),
                f64::from(*FACE_PX_RANGE.end()),
            )?;
        }
        Ok(())
    }
}

/// What the plugin made of a [`DomeCamera`]: whether the vertex mode's
/// projection is in Bevy's view shader, and the last refusal. Added with
/// every dome camera and kept up to date by the plugin.
#[derive(Component, Reflect, Clone, Debug, Default, PartialEq)]
#[reflect(Component, Default)]
pub struct DomeStatus {
    /// Whether the dome's branch is in Bevy's `view_transformations`
    /// shader, which every mesh's vertex shader goes through in the vertex
    /// mode: `None` until Bevy's shader has loaded, then `Some(true)`, or
    /// `Some(false)` when its text was not what this version patches (the
    /// vertex mode then draws a plain perspective; [`Self::error`] says
    /// so). The cube mode does not need it.
    pub vertex_projection: Option<bool>,
    /// Why the camera is not drawn as set: refused settings (it keeps its
    /// last good projection) or, in the vertex mode, a failed patch (of
    /// the projection, or of the exact-attribute step where
    /// [`DomeCamera::exact_attributes`] is on).
    #[reflect(ignore)]
    pub error: Option<Error>,
}

/// On a dome camera: the render layers of the scene it sees. Taken from
/// the camera's own `RenderLayers` when its [`DomeCamera`] is added (layer
/// 0 without one), since the plugin then gives the camera its dome layer
/// instead; change this component, not the camera's `RenderLayers`,
/// afterwards. A mesh gets a twin for the camera only when its own layers
/// meet these, a light lights the camera only when its layers do, and
/// the cube mode's faces see these layers.
#[derive(Component, Clone, Debug, Default, PartialEq)]
pub struct DomeSees(pub RenderLayers);

/// How a mesh's apparent size changes while the app runs: the paper's
/// classification (§3.1), which decides how its dome twin is refined. Put
/// it on a mesh entity; without it a mesh is [`Self::Changing`].
///
/// ```no_run
/// use bevy::prelude::*;
/// use optica_dome::DomeApparentSize;
///
/// fn spawn_sky_art(mut commands: Commands, art: Handle<Mesh>) {
///     // A constellation figure on the sky sphere around the viewer:
///     // split once, not each time the camera or the sky turns.
///     commands.spawn((Mesh3d(art), DomeApparentSize::NearlyConstant));
/// }
/// ```
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Component, Default)]
pub enum DomeApparentSize {
    /// It moves relative to the viewer (buildings, vehicles, scenery, large
    /// stars passing by): refined from the current view whenever it moves
    /// relative to the camera or the camera turns.
    #[default]
    Changing,
    /// It keeps its distance to the viewer and only turns about it (stars,
    /// constellation art, a sky sphere centred on the camera, diurnal
    /// motion): its triangles are split once with the paper's
    /// rotation-invariant step for the camera's tolerance, and split again
    /// only when its mesh, the camera's settings or the viewer's position
    /// in the mesh's own space change — not when it or the camera turns.
    /// Not clipped: the vertex shader drops what lies near the antipode.
    /// Lines are always refined from the view (the paper's classification).
    NearlyConstant,
}
