//! Line meshes for a planetarium sky: constellation lines, a graticule,
//! any polyline.
//!
//! Lines are first-class on a dome: a `LineList` or `LineStrip` mesh is
//! refined like a triangle's edge (clipped behind the viewer, split until
//! its chords are within the camera's tolerance of the true curved image),
//! every frame the line moves relative to the camera (the paper's
//! classification puts lines in the dynamic class). A straight segment
//! between two points on a sphere around the viewer is seen along the great
//! circle through them, so constellation lines and meridians need one
//! segment per arc (under 180°): the refinement draws the exact arc.
//!
//! Lines are drawn by the GPU's line rasteriser: one pixel wide, whatever
//! the domemaster's size. Draw wider lines as thin meshes (quads or boxes
//! along the segment), which are refined like any triangle.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use optica_dome::lines::{Graticule, segments};
//!
//! fn spawn_lines(
//!     mut commands: Commands,
//!     mut meshes: ResMut<Assets<Mesh>>,
//!     mut materials: ResMut<Assets<StandardMaterial>>,
//! ) {
//!     let line = materials.add(StandardMaterial {
//!         base_color: Color::srgb(0.4, 0.6, 1.0),
//!         unlit: true,
//!         ..default()
//!     });
//!     commands.spawn((
//!         Mesh3d(meshes.add(Graticule::default().mesh())),
//!         MeshMaterial3d(line.clone()),
//!     ));
//!     // A constellation line between two stars 500 units out.
//!     let (a, b) = (Vec3::new(0.3, 0.8, -0.5), Vec3::new(-0.2, 0.9, -0.4));
//!     commands.spawn((
//!         Mesh3d(meshes.add(segments(&[[500.0 * a.normalize(), 500.0 * b.normalize()]]))),
//!         MeshMaterial3d(line),
//!     ));
//! }
//! ```

use bevy::asset::RenderAssetUsages;
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;

/// A line-list mesh of `segments` (pairs of points in the entity's space).
pub fn segments(segments: &[[Vec3; 2]]) -> Mesh {
    let positions: Vec<[f32; 3]> = segments.iter().flatten().map(|p| p.to_array()).collect();
    line_list(positions, (0..2 * segments.len() as u32).collect())
}

/// A line-list mesh of the polyline through `points` (closed with
/// `closed`).
pub fn polyline(points: &[Vec3], closed: bool) -> Mesh {
    let n = points.len() as u32;
    let mut indices: Vec<u32> = (1..n).flat_map(|k| [k - 1, k]).collect();
    if closed && n > 2 {
        indices.extend([n - 1, 0]);
    }
    line_list(points.iter().map(|p| p.to_array()).collect(), indices)
}

fn line_list(positions: Vec<[f32; 3]>, indices: Vec<u32>) -> Mesh {
    Mesh::new(PrimitiveTopology::LineList, RenderAssetUsages::default())
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
        .with_inserted_indices(Indices::U32(indices))
}

/// The finest step a [`Graticule`] takes, in degrees.
const MIN_STEP_DEG: f32 = 0.1;

/// An altitude–azimuth grid on a sphere around the entity's origin (put
/// the viewer there): meridians every [`Self::azimuth_step_deg`] from pole
/// to pole and altitude circles every [`Self::altitude_step_deg`], the
/// pole along the entity's +Y. Turn the entity for an equatorial grid.
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Default)]
pub struct Graticule {
    /// Radius of the sphere, in world units (keep it inside the camera's
    /// far distance).
    pub radius: f32,
    /// Spacing of the altitude circles in degrees (the horizon is one).
    pub altitude_step_deg: f32,
    /// Spacing of the meridians in degrees of azimuth (rounded so that a
    /// whole number of them goes round).
    pub azimuth_step_deg: f32,
    /// Altitude circles are not great circles: they are drawn as chords of
    /// at most this many degrees of azimuth, whose sag from the true circle
    /// is at most `cos(alt)·(1 − cos(step/2))` radians (1.5·10⁻⁴ at 2°,
    /// 0.2 px on a 4K 180° dome). Meridians are great circles: four
    /// straight segments each, exact once refined.
    pub max_chord_deg: f32,
}

impl Default for Graticule {
    /// 500 units out, altitude circles every 15°, meridians every 30°,
    /// chords of 2°.
    fn default() -> Self {
        Self {
            radius: 500.0,
            altitude_step_deg: 15.0,
            azimuth_step_deg: 30.0,
            max_chord_deg: 2.0,
        }
    }
}

impl Graticule {
    /// The grid as a line-list mesh. Steps that are not finite and positive
    /// are taken as 90° (horizon and four meridians) and a bad chord as 2°,
    /// with a warning; steps are kept within [0.1°, 360°] (a finer grid
    /// would be millions of lines).
    pub fn mesh(&self) -> Mesh {
        let step = |v: f32, what: &str, fallback: f32| {
            if v.is_finite() && v > 0.0 {
                v.clamp(MIN_STEP_DEG, 360.0)
            } else {
                warn!("optica_dome: graticule {what} {v} deg is not positive; using {fallback}");
                fallback
            }
        };
        let alt_step = step(self.altitude_step_deg, "altitude step", 90.0);
        let az_step = step(self.azimuth_step_deg, "azimuth step", 90.0);
        let chord = step(self.max_chord_deg, "chord", 2.0);
        let r = self.radius;
        let at = |alt: f32, az: f32| {
            let (alt, az) = (alt.to_radians(), az.to_radians());
            r * Vec3::new(alt.cos() * az.sin(), alt.sin(), -alt.cos() * az.cos())
        };
        let mut lines = Vec::new();
        let meridians = (360.0 / az_step).round().max(1.0) as u32;
        for m in 0..meridians {
            let az = m as f32 * 360.0 / meridians as f32;
            for k in 0..4 {
                let alt = -90.0 + 45.0 * k as f32;
                lines.push([at(alt, az), at(alt + 45.0, az)]);
            }
        }
        let circles = (90.0 / alt_step).floor() as i32;
        let pieces = (360.0 / chord).ceil().max(3.0) as u32;
        for k in -circles..=circles {
            let alt = k as f32 * alt_step;
            if alt.abs() >= 90.0 {
                continue;
            }
            for i in 0..pieces {
                let az = |i: u32| i as f32 * 360.0 / pieces as f32;
                lines.push([at(alt, az(i)), at(alt, az(i + 1))]);
            }
        }
        segments(&lines)
    }
}
