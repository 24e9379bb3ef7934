//! The dome camera's `Projection`: what Bevy's CPU side (culling, light
//! clusters, shadow cascades) sees, and the parameters the vertex shader
//! reads back from `clip_from_view` (`shaders/projection.wgsl`).

use bevy::camera::CameraProjection;
use bevy::camera::primitives::Frustum;
use bevy::math::primitives::{HalfSpace, ViewFrustum};
use bevy::math::{Mat4, Vec3, Vec3A, Vec4};
use bevy::prelude::*;

/// `clip_from_view[2][2] = THETA_SCALE·θ_max`: small, so that Bevy's CPU
/// code, which reads the matrix as an infinite reverse-Z perspective, sees
/// depths off by at most 3e-4 in NDC.
pub(crate) const THETA_SCALE: f32 = 1.0e-4;
/// `clip_from_view[3][0] = LENS_MARK·(1 + lens + INTERPOLATED·k)`, the
/// lens's number (0 equidistant … 4 polynomial, 5 equirectangular) and
/// k = 1 where the camera leaves attributes interpolated
/// (`DomeCamera::exact_attributes` off): it marks the matrix as a dome
/// camera's for the shader. A clip-space x offset of 1e-3 at most 1.4e-2,
/// which no ordinary projection has.
pub(crate) const LENS_MARK: f32 = 1.0e-3;
/// What `exact_attributes: false` adds to the lens's number in the mark.
pub(crate) const INTERPOLATED: u32 = 8;

/// The projection of a [`crate::DomeCamera`], kept in the camera's
/// `Projection::custom` by the plugin. Not meant to be built by hand.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DomeClip {
    /// Half the field of view, radians, in `(0, π)`.
    pub theta_max: f32,
    /// Forward tilt of the dome axis, radians.
    pub tilt: f32,
    /// Nearest drawn distance from the camera.
    pub near: f32,
    /// Farthest distance culling considers.
    pub far: f32,
    /// The radial mapping.
    pub lens: crate::DomeLens,
    /// NDC per image-circle radius along x and y: 1 on the shorter side of
    /// the target, less on the longer one (the circle fits the shorter
    /// side). Kept up to date from the target's size by Bevy.
    pub scale: Vec2,
    /// Whether fragments take their own ray's attributes
    /// (`DomeCamera::exact_attributes`).
    pub exact_attributes: bool,
}

impl DomeClip {
    /// The projection of `camera`'s settings.
    pub fn of(camera: &crate::DomeCamera) -> Self {
        // The panorama has no rim; the shader only needs a valid angle to
        // recognise the matrix.
        let theta_max = if camera.lens == crate::DomeLens::Equirectangular {
            std::f32::consts::FRAC_PI_2
        } else {
            0.5 * camera.fov_deg.to_radians()
        };
        Self {
            theta_max,
            tilt: camera.tilt_deg.to_radians(),
            near: camera.near,
            far: camera.far,
            lens: camera.lens,
            scale: Vec2::ONE,
            exact_attributes: camera.exact_attributes,
        }
    }

    /// The lens's number in the shader (`projection.wgsl`) and its
    /// polynomial's shape k₂/k₁, k₃/k₁, k₄/k₁ (zero for the other lenses).
    pub fn lens_code(&self) -> (u32, Vec3) {
        match self.lens {
            crate::DomeLens::Equidistant => (0, Vec3::ZERO),
            crate::DomeLens::Equisolid => (1, Vec3::ZERO),
            crate::DomeLens::Stereographic => (2, Vec3::ZERO),
            crate::DomeLens::Orthographic => (3, Vec3::ZERO),
            crate::DomeLens::Polynomial { k } => (4, Vec3::new(k[1], k[2], k[3]) / k[0]),
            crate::DomeLens::Equirectangular => (5, Vec3::ZERO),
        }
    }

    /// The dome frame in view space: (image right, image up, axis), as in
    /// `optica_optics::dome::DomeProjection` (tilt leans the axis forward,
    /// from −Z towards −Y).
    pub fn frame(&self) -> (Vec3, Vec3, Vec3) {
        let (s, c) = self.tilt.sin_cos();
        (Vec3::X, Vec3::new(0.0, c, -s), Vec3::new(0.0, -s, -c))
    }

    /// `clip_from_view` = S·R: R rotates view space into the dome frame
    /// with the axis along −Z, S is an infinite reverse-Z perspective of
    /// focals `scale` and near plane `near` that carries the rest of the
    /// projection for the vertex shader (`projection.wgsl`): θ_max in
    /// `S[2][2]`, the lens's number in the clip-x offset, and a
    /// polynomial's shape in the clip-y offset and the x column of rows y
    /// and z (entries the shader reads back directly, since image right is
    /// view +X).
    pub fn clip_from_view(&self) -> Mat4 {
        let (right, up, axis) = self.frame();
        // Rows of R: right, up, −axis.
        let r = Mat4::from_cols(
            Vec4::new(right.x, up.x, -axis.x, 0.0),
            Vec4::new(right.y, up.y, -axis.y, 0.0),
            Vec4::new(right.z, up.z, -axis.z, 0.0),
            Vec4::W,
        );
        let (lens, shape) = self.lens_code();
        let interpolated = if self.exact_attributes {
            0
        } else {
            INTERPOLATED
        };
        let mark = LENS_MARK * (1 + lens + interpolated) as f32;
        let s = Mat4::from_cols(
            Vec4::new(self.scale.x, shape.y, shape.z, 0.0),
            Vec4::new(0.0, self.scale.y, 0.0, 0.0),
            Vec4::new(0.0, 0.0, THETA_SCALE * self.theta_max, -1.0),
            Vec4::new(mark, shape.x, self.near, 0.0),
        );
        s * r
    }

    /// Whether the visible set lies in front of the dome's view plane
    /// (a fisheye of FOV ≤ 180°; the panorama sees all around).
    pub fn hemisphere(&self) -> bool {
        self.lens != crate::DomeLens::Equirectangular
            && self.theta_max <= std::f32::consts::FRAC_PI_2
    }
}

impl CameraProjection for DomeClip {
    fn get_clip_from_view(&self) -> Mat4 {
        self.clip_from_view()
    }

    fn get_clip_from_view_for_sub(&self, _sub_view: &bevy::camera::SubCameraView) -> Mat4 {
        // A domemaster is one image; sub-views (tiles) are not supported.
        self.clip_from_view()
    }

    fn update(&mut self, width: f32, height: f32) {
        // The image circle fits the shorter side; the panorama fills the
        // target.
        if self.lens == crate::DomeLens::Equirectangular {
            self.scale = Vec2::ONE;
        } else if width > 0.0 && height > 0.0 {
            let short = width.min(height);
            self.scale = Vec2::new(short / width, short / height);
        }
    }

    fn far(&self) -> f32 {
        self.far
    }

    /// A box around what the dome sees up to `|z_far|` (Bevy passes view
    /// z, negative in front): the half-space in front of the view plane for
    /// FOV ≤ 180°, all around otherwise. Shadow cascades fit their maps to
    /// it.
    fn get_frustum_corners(&self, _z_near: f32, z_far: f32) -> [Vec3A; 8] {
        let (right, up, axis) = self.frame();
        let r = z_far.abs();
        let behind = if self.hemisphere() { 0.0 } else { r };
        // Distances along the dome axis (in front is positive).
        let corner = |x: f32, y: f32, d: f32| Vec3A::from(x * right + y * up + d * axis);
        // A slice of distances [near, far] of a fisheye reaches sideways to
        // the view plane (and behind it beyond 180°), so every slice's box
        // starts there.
        let z_far = r;
        let near = -behind;
        [
            corner(r, -r, near),
            corner(r, r, near),
            corner(-r, r, near),
            corner(-r, -r, near),
            corner(r, -r, z_far),
            corner(r, r, z_far),
            corner(-r, r, z_far),
            corner(-r, -r, z_far),
        ]
    }

    /// Culling for a fisheye: the view plane through the camera (FOV ≤ 180°;
    /// wider domes see all around) and a box of half-size `far` around it
    /// (Bevy's mesh culling leaves out its sixth side, +Z).
    fn compute_frustum(&self, camera_transform: &GlobalTransform) -> Frustum {
        let (_, _, axis) = self.frame();
        let world_axis = camera_transform
            .affine()
            .transform_vector3(axis)
            .normalize_or(Vec3::NEG_Z);
        let origin = camera_transform.translation();
        // Inside: normal·p + d > 0.
        let facing = |n: Vec3, d: f32| HalfSpace::new(n.extend(d));
        let box_side = |n: Vec3| facing(n, -n.dot(origin) + self.far);
        let front = if self.hemisphere() {
            facing(world_axis, -world_axis.dot(origin))
        } else {
            box_side(Vec3::NEG_Z)
        };
        Frustum(ViewFrustum {
            half_spaces: [
                box_side(Vec3::X),
                box_side(Vec3::NEG_X),
                box_side(Vec3::Y),
                box_side(Vec3::NEG_Y),
                front,
                box_side(Vec3::Z),
            ],
        })
    }
}
