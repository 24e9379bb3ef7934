//! CAVE walls: a point on a wall lands on the wall image's pixel there
//! (lavapipe), the projection matches the CPU twin, and an eye on, behind
//! or outside the walls gives finite cameras.

use bevy::camera::ClearColorConfig;
use bevy::prelude::*;
use optica_foveated_lod::{
    CaveView, Eye, FoveatedLodPlugin, HeadSource, OffAxisClip, TrackedHead, WallRect, aim,
};
use optica_harness::Headless;
use optica_optics::foveated_lod::DepthConvention;

const SIZE: u32 = 64;

/// Renders `wall` from `eye` with a 6 cm white square on the wall at (s, t)
/// and returns the centroid of the bright pixels.
fn marker_centroid(wall: WallRect, eye: Vec3, s: f32, t: f32) -> Vec2 {
    let frame = Headless::new(SIZE, SIZE)
        .frames(3)
        .render(move |app: &mut App| {
            app.add_plugins(FoveatedLodPlugin)
                .insert_resource(HeadSource::External)
                .insert_resource(TrackedHead::looking(eye, Quat::IDENTITY, None, 0.0))
                .add_systems(
                    Startup,
                    move |mut commands: Commands,
                          mut meshes: ResMut<Assets<Mesh>>,
                          mut materials: ResMut<Assets<StandardMaterial>>| {
                        let u = wall.lower_right - wall.lower_left;
                        let v = wall.upper_left - wall.lower_left;
                        let n = u.cross(v).normalize();
                        let at = wall.lower_left + s * u + t * v + 0.001 * n;
                        commands.spawn((
                            Mesh3d(meshes.add(Rectangle::new(0.06, 0.06))),
                            MeshMaterial3d(materials.add(StandardMaterial {
                                base_color: Color::WHITE,
                                unlit: true,
                                ..default()
                            })),
                            Transform::from_translation(at).looking_to(-n, v.normalize()),
                        ));
                        commands.spawn((
                            CaveView::new(wall, Eye::Cyclopean),
                            Camera {
                                clear_color: ClearColorConfig::Custom(Color::BLACK),
                                ..default()
                            },
                            Msaa::Off,
                        ));
                    },
                );
        })
        .expect("render")
        .to_rgba8();
    let (mut sum, mut n) = (Vec2::ZERO, 0.0);
    for (x, y, p) in frame.enumerate_pixels() {
        if p[0] > 128 {
            sum += Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            n += 1.0;
        }
    }
    assert!(n > 0.0, "the marker is not in the image");
    sum / n
}

/// The paper's CAVE (3 m), eye off-centre: a point on the front and on the
/// floor lands where the wall's own image has it (within half a pixel).
#[test]
fn a_point_on_a_wall_projects_to_its_pixel() {
    let [front, _, floor] = WallRect::front_right_floor(3.0).unwrap();
    let eye = Vec3::new(0.45, 1.3, 0.6);
    for (name, wall, s, t) in [("front", front, 0.3, 0.7), ("floor", floor, 0.65, 0.4)] {
        let c = marker_centroid(wall, eye, s, t);
        let expected = Vec2::new(s * SIZE as f32, (1.0 - t) * SIZE as f32);
        eprintln!("{name}: marker at {c:?}, expected {expected:?}");
        assert!(c.distance(expected) < 0.5, "{name}: {c:?} vs {expected:?}");
    }
}

/// The camera's clip-from-world equals the CPU twin's view-projection, and
/// an eye on, behind or far outside a wall, or at a wall's seam, gives
/// finite matrices with the eye moved in front.
#[test]
fn off_axis_cameras_match_the_twin_and_stay_finite() {
    let walls = WallRect::front_right_floor(3.0).unwrap();
    let eye = Vec3::new(-0.3, 1.7, 0.2);
    for wall in walls {
        let view = CaveView::new(wall, Eye::Cyclopean);
        let (transform, clip): (Transform, OffAxisClip) = aim(&view, eye).unwrap();
        let ours = clip.clip_from_view * transform.to_matrix().inverse();
        let twin = wall
            .wall()
            .unwrap()
            .off_axis(eye.as_dvec3(), 0.05, 1.0, DepthConvention::ReverseInfinite)
            .unwrap()
            .view_projection()
            .as_mat4();
        assert!(ours.abs_diff_eq(twin, 1e-4), "{ours:?}\n{twin:?}");
    }
    // Seam (front/right corner), on the floor, behind the front wall, far outside.
    for eye in [
        Vec3::new(1.5, 1.5, -1.5),
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(0.0, 1.5, -2.5),
        Vec3::new(40.0, -7.0, 90.0),
    ] {
        for wall in walls {
            let view = CaveView::new(wall, Eye::Cyclopean);
            let (t, clip) = aim(&view, eye).unwrap();
            assert!(t.translation.is_finite() && t.rotation.is_finite());
            assert!(clip.clip_from_view.is_finite(), "{eye:?}");
            let d = wall
                .wall()
                .unwrap()
                .signed_distance(t.translation.as_dvec3());
            assert!(d >= 0.0099, "eye {eye:?}: {d} m in front");
        }
    }
    assert!(aim(&CaveView::new(walls[0], Eye::Cyclopean), Vec3::NAN).is_err());
}

/// Stereo as the paper ran it: each wall has a camera per eye, placed at
/// that eye; with per-eye fields, a point 75° to the left is in the left
/// eye's field (ear side, 100°) and outside the right eye's (nose side, 60°).
#[test]
fn stereo_walls_follow_each_eye_with_its_own_field() {
    use optica_foveated_lod::{FieldEyes, Foveation, GazeState};
    let mut app = super::cpu_app();
    app.insert_resource(HeadSource::External)
        .insert_resource(TrackedHead::looking(
            Vec3::new(0.1, 1.6, 0.2),
            Quat::IDENTITY,
            None,
            0.064,
        ))
        .insert_resource(Foveation {
            eyes: FieldEyes::PerEye,
            ..default()
        });
    let [front, _, _] = WallRect::front_right_floor(3.0).unwrap();
    let left = app.world_mut().spawn(CaveView::new(front, Eye::Left)).id();
    let right = app.world_mut().spawn(CaveView::new(front, Eye::Right)).id();
    for _ in 0..3 {
        app.update();
    }
    let at = |e: Entity| app.world().get::<Transform>(e).unwrap().translation;
    assert!(
        at(left).distance(Vec3::new(0.1 - 0.032, 1.6, 0.2)) < 1e-5,
        "{:?}",
        at(left)
    );
    assert!(
        at(right).distance(Vec3::new(0.1 + 0.032, 1.6, 0.2)) < 1e-5,
        "{:?}",
        at(right)
    );
    let gaze = app.world().resource::<GazeState>();
    let a = 75f64.to_radians();
    let dir = optica_optics::glam::DVec3::new(-a.sin(), 0.0, -a.cos());
    let (l, r) = (gaze.level(Eye::Left, dir), gaze.level(Eye::Right, dir));
    eprintln!("75° left: left eye level {l:.3}, right eye {r:.3}");
    assert!((l - 25.0 / 70.0).abs() < 1e-9 && r == 0.0, "{l} {r}");
}
