//! One type for every projection a panoramic camera can have: a radial
//! fisheye ([`DomeProjection`]) or the equirectangular panorama
//! ([`EquirectProjection`]), so a renderer can project and refine without
//! caring which.

use glam::{DVec2, DVec3};

use super::camera::DomeProjection;
use super::equirect::EquirectProjection;
use super::equirect_refine::{
    refine_mesh_equirect, refine_segment_equirect, refine_triangle_equirect,
};
use super::error::DomeError;
use super::projection::Projected;
use super::refine::{RefinedSegment, refine_segment};
use super::rule::SplitRule;
use super::triangle::{RefinedMesh, TriMesh, is_left_whole, refine_mesh, refine_triangle};

/// A checked panoramic projection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Panorama {
    /// A radial fisheye: a domemaster or a fisheye lens's image circle.
    Fisheye(DomeProjection),
    /// 360° × 180° of longitude and latitude.
    Equirectangular(EquirectProjection),
}

impl Panorama {
    /// Projects a view-space point.
    pub fn project(&self, p: DVec3) -> Projected {
        match self {
            Self::Fisheye(f) => f.project(p),
            Self::Equirectangular(e) => e.project(p),
        }
    }

    /// Pixel of a view-space direction, where it has one.
    pub fn pixel_of_direction(&self, d: DVec3) -> Option<DVec2> {
        match self {
            Self::Fisheye(f) => f.pixel_of_direction(d),
            Self::Equirectangular(e) => e.pixel_of_direction(d),
        }
    }

    /// Unit view-space direction seen at a pixel; `None` where the image
    /// shows nothing (outside a fisheye's circle, outside the image).
    pub fn unproject(&self, pixel: DVec2) -> Option<DVec3> {
        match self {
            Self::Fisheye(f) => f.unproject(pixel),
            Self::Equirectangular(e) => e.unproject(pixel),
        }
    }

    /// Image width and height in px.
    pub fn size_px(&self) -> DVec2 {
        match self {
            Self::Fisheye(f) => DVec2::new(f.size_px(), f.height_px()),
            Self::Equirectangular(e) => e.size_px(),
        }
    }

    /// Refines a mesh (view space): [`refine_mesh`] or
    /// [`refine_mesh_equirect`](super::refine_mesh_equirect).
    pub fn refine_mesh(&self, mesh: &TriMesh, rule: SplitRule) -> RefinedMesh {
        match self {
            Self::Fisheye(f) => refine_mesh(f, mesh, rule),
            Self::Equirectangular(e) => refine_mesh_equirect(e, mesh, rule),
        }
    }

    /// Refines one triangle (view space): [`refine_triangle`] or
    /// [`refine_triangle_equirect`](super::refine_triangle_equirect).
    pub fn refine_triangle(
        &self,
        tri: [DVec3; 3],
        rule: SplitRule,
    ) -> Result<RefinedMesh, DomeError> {
        match self {
            Self::Fisheye(f) => refine_triangle(f, tri, rule),
            Self::Equirectangular(e) => refine_triangle_equirect(e, tri, rule),
        }
    }

    /// Whether [`Self::refine_triangle`] gives `tri` (view space, finite)
    /// back as it is, by a test much cheaper than refining
    /// ([`is_left_whole`] for a fisheye). Always `false` for the panorama,
    /// whose rule has no scene-wide bound on curvature (it grows without
    /// limit at the poles).
    pub fn leaves_whole(&self, tri: [DVec3; 3], rule: SplitRule) -> bool {
        match self {
            Self::Fisheye(f) => is_left_whole(f, tri, rule),
            Self::Equirectangular(_) => false,
        }
    }

    /// Whether [`Self::refine_triangle`] gives nothing for `tri` (view
    /// space, finite) because it lies wholly behind the view plane of a
    /// fisheye that clips there (half of every scene around a dome): a
    /// renderer can skip it without calling the refiner. Always `false`
    /// for the panorama, which sees every direction.
    pub fn leaves_out(&self, tri: [DVec3; 3]) -> bool {
        match self {
            Self::Fisheye(f) => {
                f.clips_at_view_plane() && tri.iter().all(|v| v.dot(f.axis()) < 0.0)
            }
            Self::Equirectangular(_) => false,
        }
    }

    /// Refines one segment (view space): [`refine_segment`] or
    /// [`refine_segment_equirect`](super::refine_segment_equirect).
    pub fn refine_segment(
        &self,
        a: DVec3,
        b: DVec3,
        rule: SplitRule,
    ) -> Result<RefinedSegment, DomeError> {
        match self {
            Self::Fisheye(f) => refine_segment(f, a, b, rule),
            Self::Equirectangular(e) => refine_segment_equirect(e, a, b, rule),
        }
    }

    /// The fisheye, if it is one.
    pub fn fisheye(&self) -> Option<&DomeProjection> {
        match self {
            Self::Fisheye(f) => Some(f),
            Self::Equirectangular(_) => None,
        }
    }
}

impl From<DomeProjection> for Panorama {
    fn from(f: DomeProjection) -> Self {
        Self::Fisheye(f)
    }
}

impl From<EquirectProjection> for Panorama {
    fn from(e: EquirectProjection) -> Self {
        Self::Equirectangular(e)
    }
}
