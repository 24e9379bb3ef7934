//! CAVE walls: a camera per wall (and per eye) with the off-axis projection
//! from the tracked eye ([`CaveView`]).

use bevy::camera::CameraProjection;
use bevy::math::Vec3A;
use bevy::prelude::*;
use optica_optics::foveated_lod::{CaveWall, DepthConvention, FoveatedError, front_right_floor};
use optica_optics::glam::DVec3;

use crate::head::{Eye, GazeState, TrackedHead};
use crate::settings::{CaveView, WallRect};

impl WallRect {
    /// The paper's CAVE (front, right and floor screens) for a cube of side
    /// `size` m, floor at y = 0, centred on x = z = 0; the front wall faces
    /// +Z. `None` for a size that is not positive and finite.
    pub fn front_right_floor(size: f32) -> Option<[WallRect; 3]> {
        let walls = front_right_floor(size as f64).ok()?;
        Some(walls.map(|w| WallRect {
            lower_left: w.lower_left().as_vec3(),
            lower_right: w.lower_right().as_vec3(),
            upper_left: w.upper_left().as_vec3(),
        }))
    }

    /// The checked wall of the CPU twin.
    pub fn wall(&self) -> Result<CaveWall, FoveatedError> {
        CaveWall::new(
            self.lower_left.as_dvec3(),
            self.lower_right.as_dvec3(),
            self.upper_left.as_dvec3(),
        )
    }

    /// Width over height, the aspect its camera's target should have.
    pub fn aspect(&self) -> f32 {
        (self.lower_right - self.lower_left).length() / (self.upper_left - self.lower_left).length()
    }
}

impl CaveView {
    /// The view of `wall` from `eye`, near 0.05 m, far 1000 m, the eye kept
    /// at least 1 cm in front.
    pub fn new(wall: WallRect, eye: Eye) -> Self {
        Self {
            wall,
            eye,
            near: 0.05,
            far: 1000.0,
            min_eye_distance: 0.01,
        }
    }
}

/// What the plugin made of a [`CaveView`]: why its wall's projection was
/// not updated, if it was not (the camera then keeps its last one). Added
/// with every `CaveView` and kept up to date by the plugin.
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Component, Default)]
pub struct CaveViewStatus {
    /// The last refusal (a wall that is not a rectangle, a non-finite
    /// setting), cleared when the view is aimed again.
    #[reflect(ignore)]
    pub error: Option<FoveatedError>,
}

/// The off-axis projection the plugin gives a [`CaveView`] camera
/// (reverse-Z, infinite far plane, as Bevy's own perspective).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OffAxisClip {
    /// Clip from view.
    pub clip_from_view: Mat4,
    /// Frustum extents on the near plane: left, right, bottom, top.
    pub extents: [f32; 4],
    /// Near distance.
    pub near: f32,
    /// Culling distance.
    pub far: f32,
}

impl CameraProjection for OffAxisClip {
    fn get_clip_from_view(&self) -> Mat4 {
        self.clip_from_view
    }

    fn get_clip_from_view_for_sub(&self, _sub_view: &bevy::camera::SubCameraView) -> Mat4 {
        // A wall is one image; sub-views are not supported.
        self.clip_from_view
    }

    // The frustum is the wall's, whatever the target's size.
    fn update(&mut self, _width: f32, _height: f32) {}

    fn far(&self) -> f32 {
        self.far
    }

    fn get_frustum_corners(&self, z_near: f32, z_far: f32) -> [Vec3A; 8] {
        let [l, r, b, t] = self.extents;
        let at = |x: f32, y: f32, z: f32| {
            let k = z.abs() / self.near;
            Vec3A::new(x * k, y * k, z)
        };
        // Bevy's order: bottom right, top right, top left, bottom left; near then far.
        [
            at(r, b, z_near),
            at(r, t, z_near),
            at(l, t, z_near),
            at(l, b, z_near),
            at(r, b, z_far),
            at(r, t, z_far),
            at(l, t, z_far),
            at(l, b, z_far),
        ]
    }
}

/// The eye a wall is projected from, its camera transform and projection;
/// `None` with the reason when the wall is degenerate or the numbers are
/// not finite.
pub fn aim(view: &CaveView, eye: Vec3) -> Result<(Transform, OffAxisClip), FoveatedError> {
    let wall = view.wall.wall()?;
    let (vr, vu, vn) = wall.basis();
    let mut e = optica_optics::input::finite_vec3("tracked eye (m)", eye.as_dvec3())?;
    let min = (view.min_eye_distance.max(0.0) as f64).max(1e-6);
    let d = wall.signed_distance(e);
    if d < min {
        e += vn * (min - d);
    }
    let near = view.near as f64;
    let p = wall.off_axis(e, near, f64::INFINITY, DepthConvention::ReverseInfinite)?;
    let rotation = Quat::from_mat3(&Mat3::from_cols(vr.as_vec3(), vu.as_vec3(), vn.as_vec3()));
    let [l, r, b, t] = p.extents;
    Ok((
        Transform {
            translation: e.as_vec3(),
            rotation,
            scale: Vec3::ONE,
        },
        OffAxisClip {
            clip_from_view: p.projection.as_mat4(),
            extents: [l as f32, r as f32, b as f32, t as f32],
            near: view.near,
            far: view.far,
        },
    ))
}

/// Places every [`CaveView`] camera at its eye with its wall's projection,
/// when the head or the view changed.
pub(crate) fn aim_cave_views(
    head: Res<TrackedHead>,
    gaze: Res<GazeState>,
    mut views: Query<(
        Entity,
        Ref<CaveView>,
        &mut Transform,
        &mut Projection,
        &mut CaveViewStatus,
    )>,
    mut work: ResMut<crate::lod::FoveationWork>,
) {
    let head_moved = head.is_changed() || gaze.is_changed();
    for (entity, view, mut transform, mut projection, mut status) in &mut views {
        if !(head_moved || view.is_changed()) {
            continue;
        }
        let tracked = head.eye_position(view.eye);
        let eye = if head.valid && tracked.is_finite() {
            Some(tracked)
        } else {
            gaze.estimate(view.eye).eye().map(DVec3::as_vec3)
        };
        let Some(eye) = eye else {
            continue;
        };
        match aim(&view, eye) {
            Ok((t, clip)) => {
                work.views_aimed += 1;
                transform.set_if_neq(t);
                *projection = Projection::custom(clip);
                if status.error.is_some() {
                    status.error = None;
                }
            }
            Err(e) => {
                if view.is_changed() {
                    warn!("foveated LOD: CAVE view {entity} is not updated: {e}");
                }
                if status.error.as_ref() != Some(&e) {
                    status.error = Some(e);
                }
            }
        }
    }
}
