//! CAVE walls: a point on a wall lands on the wall image's pixel there
//! (lavapipe), the projection matches the CPU twin, and an eye on, behind
//! or outside the walls gives finite cameras.

use bevy::camera::ClearColorConfig;
use bevy::prelude::*;
use optica_foveated_lod::{
    CaveView, Eye, FoveatedLodPlugin, HeadSource, TrackedHead, WallRect,
};
use optica_foveated_lod::twins::{OffAxisClip, aim};
use optica_harness::Headless;
use optica_optics::foveated_lod::DepthConvention;

const SIZE: u32 = 64;

/// The cyclopean eye's camera of `wall`, drawing on black.
fn wall_camera(wall: WallRect) -> impl Bundle {
    (
        CaveView::new(wall, Eye::Cyclopean),
        Camera {
            clear_color: ClearColorConfig::Custom(Color::BLACK),
            ..default()
        },
        Msaa::Off,
    )
}

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
                        commands.spawn(wall_camera(wall));
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

/// Where the moving eye of [`walls_agree_in_the_frame_the_head_moves`] is
/// in frame `n` (counting updates from 1): 4.5 cm a frame, across, up and
/// towards the front wall (2.7 m/s at 60 Hz; the lag this test guards
/// against grows with the step).
fn moving_eye(n: u32) -> Vec3 {
    Vec3::new(-0.2, 1.2, 0.3) + n as f32 * Vec3::new(0.03, 0.02, -0.025)
}

/// The eye of the current update, as the test set it (main world), and as
/// the render world received it.
#[derive(Resource, Clone, Copy, Default, bevy::render::extract_resource::ExtractResource)]
struct EyeNow {
    frame: u32,
    eye: Vec3,
}

/// What the render world drew each frame: the frame, its eye, and the
/// wall camera's clip-from-world.
type Drawn = std::sync::Arc<std::sync::Mutex<Vec<(u32, Vec3, Mat4)>>>;

#[derive(Resource, Clone)]
struct DrawnLog(Drawn);

/// The NDC where an off-axis wall view from `eye` draws `p`, found without
/// any matrix: the ray from the eye through `p` meets the wall's plane at
/// wall coordinates (s, t) ∈ [0, 1]², which the wall's image spans.
fn ndc_through_wall(wall: WallRect, eye: Vec3, p: Vec3) -> Vec2 {
    let (eye, p) = (eye.as_dvec3(), p.as_dvec3());
    let ll = wall.lower_left.as_dvec3();
    let u = wall.lower_right.as_dvec3() - ll;
    let v = wall.upper_left.as_dvec3() - ll;
    let n = u.cross(v);
    let k = (ll - eye).dot(n) / (p - eye).dot(n);
    let x = eye + k * (p - eye) - ll;
    let (s, t) = (x.dot(u) / u.length_squared(), x.dot(v) / v.length_squared());
    Vec2::new((2.0 * s - 1.0) as f32, (2.0 * t - 1.0) as f32)
}

/// A bright strip `h` m tall lying 1 mm in front of `wall`, from s0 to s1
/// across it, centred at height fraction `t`.
fn strip_on(wall: WallRect, s0: f32, s1: f32, t: f32, h: f32) -> (Cuboid, Transform) {
    let u = wall.lower_right - wall.lower_left;
    let v = wall.upper_left - wall.lower_left;
    let n = u.cross(v).normalize();
    let centre = wall.lower_left + (s0 + s1) / 2.0 * u + t * v + 0.001 * n;
    let size = Vec3::new((s1 - s0) * u.length(), h, 0.0002);
    (
        Cuboid::from_size(size),
        Transform::from_translation(centre).looking_to(-n, v.normalize()),
    )
}

/// Renders `wall` of the paper's CAVE while the eye moves every frame, with
/// a strip across the front/right seam, and returns the image and, per
/// frame, the eye and the clip-from-world the render world drew with; also
/// the ordering conflicts between the plugin's camera systems and Bevy's
/// camera update that the schedule reports.
fn render_moving(
    wall: WallRect,
    size: u32,
    frames: u32,
) -> (image::RgbaImage, Vec<(u32, Vec3, Mat4)>, Vec<String>) {
    use bevy::render::camera::ExtractedCamera;
    use bevy::render::extract_resource::ExtractResourcePlugin;
    use bevy::render::view::ExtractedView;
    use bevy::render::{Render, RenderApp, RenderSystems};

    let [front, right, _] = WallRect::front_right_floor(3.0).unwrap();
    let drawn: Drawn = Default::default();
    let log = DrawnLog(drawn.clone());
    let conflicts = std::sync::Arc::new(std::sync::Mutex::new(Vec::<String>::new()));
    let found = conflicts.clone();
    let frame = Headless::new(size, size)
        .frames(frames)
        .render(move |app: &mut App| {
            app.add_plugins((
                FoveatedLodPlugin,
                ExtractResourcePlugin::<EyeNow>::default(),
            ))
            .insert_resource(HeadSource::External)
            .init_resource::<EyeNow>()
            .add_systems(
                Update,
                |mut now: ResMut<EyeNow>, mut head: ResMut<TrackedHead>| {
                    now.frame += 1;
                    now.eye = moving_eye(now.frame);
                    *head = TrackedHead::looking(now.eye, Quat::IDENTITY, None, 0.0);
                },
            )
            .add_systems(Last, move |world: &mut World| {
                let mut found = found.lock().unwrap();
                if !found.is_empty() {
                    return;
                }
                let schedules = world.resource::<Schedules>();
                let post = schedules.get(PostUpdate).expect("PostUpdate");
                // The executable schedule holds the systems once it
                // has run; the graph keeps their conflicts by key.
                let names: std::collections::HashMap<_, _> = post
                    .systems()
                    .expect("PostUpdate has run")
                    .map(|(key, system)| (key, system.name().to_string()))
                    .collect();
                let ours =
                    |s: &str| s.contains("aim_cave_views") || s.contains("prepare_tracer_views");
                for (a, b, _) in post.graph().conflicting_systems().iter() {
                    let (a, b) = (&names[a], &names[b]);
                    if (ours(a) && b.contains("camera_system"))
                        || (ours(b) && a.contains("camera_system"))
                    {
                        found.push(format!("{a} / {b}"));
                    }
                }
                // A probe that the names are there to be found.
                assert!(names.values().any(|n| n.contains("aim_cave_views")));
                assert!(names.values().any(|n| n.contains("camera_system")));
                found.push("checked".into());
            })
            .add_systems(
                Startup,
                move |mut commands: Commands,
                      mut meshes: ResMut<Assets<Mesh>>,
                      mut materials: ResMut<Assets<StandardMaterial>>| {
                    let white = materials.add(StandardMaterial {
                        base_color: Color::WHITE,
                        unlit: true,
                        ..default()
                    });
                    // The strip crosses the seam: the front wall's right
                    // edge meets the right wall's left edge.
                    for (on, s0, s1) in [(front, 0.9, 1.0), (right, 0.0, 0.1)] {
                        let (cuboid, at) = strip_on(on, s0, s1, SEAM_T, 0.08);
                        commands.spawn((
                            Mesh3d(meshes.add(cuboid)),
                            MeshMaterial3d(white.clone()),
                            at,
                        ));
                    }
                    commands.spawn(wall_camera(wall));
                },
            );
            let render = app.sub_app_mut(RenderApp);
            render.insert_resource(log).add_systems(
                Render,
                (|views: Query<&ExtractedView, With<ExtractedCamera>>,
                  now: Res<EyeNow>,
                  log: Res<DrawnLog>| {
                    for view in &views {
                        let clip_from_world = view.clip_from_world.unwrap_or(
                            view.clip_from_view * view.world_from_view.to_matrix().inverse(),
                        );
                        log.0
                            .lock()
                            .unwrap()
                            .push((now.frame, now.eye, clip_from_world));
                    }
                })
                .in_set(RenderSystems::Prepare),
            );
        })
        .expect("render")
        .to_rgba8();
    let drawn = drawn.lock().unwrap().clone();
    let conflicts = conflicts.lock().unwrap().clone();
    (frame, drawn, conflicts)
}

/// Height fraction of the seam strip.
const SEAM_T: f32 = 0.4;

/// The centroid row of the bright pixels in `column`.
fn bright_row(frame: &image::RgbaImage, column: u32) -> Option<f32> {
    let (mut sum, mut n) = (0.0, 0.0);
    for y in 0..frame.height() {
        if frame.get_pixel(column, y)[0] > 128 {
            sum += y as f32 + 0.5;
            n += 1.0;
        }
    }
    (n > 0.0).then(|| sum / n)
}

/// With the eye moving every frame, every wall is drawn with the
/// projection of the same head sample as its transform, in the frame that
/// sample arrives: each frame's clip-from-world puts the wall's corners and
/// points in front of and behind it where the ray from that frame's eye
/// crosses the wall (≤ 1e-4 NDC), and a strip across the front/right seam
/// is drawn at the same height by both walls. Bevy's camera update must
/// not run between the plugin's aiming and the tracer's reading of the
/// camera (no ordering ambiguity reported).
#[test]
fn walls_agree_in_the_frame_the_head_moves() {
    const N: u32 = 128;
    const FRAMES: u32 = 8;
    let [front, right, floor] = WallRect::front_right_floor(3.0).unwrap();
    let mut seam_rows = Vec::new();
    for (name, wall) in [("front", front), ("right", right), ("floor", floor)] {
        let (image, drawn, conflicts) = render_moving(wall, N, FRAMES);
        assert_eq!(
            conflicts,
            vec!["checked".to_string()],
            "systems ordered ambiguously against Bevy's camera update"
        );
        let frames: Vec<u32> = drawn.iter().map(|d| d.0).collect();
        assert!(
            (1..=FRAMES).all(|n| frames.contains(&n)),
            "{name}: frames drawn {frames:?}"
        );
        let u = wall.lower_right - wall.lower_left;
        let v = wall.upper_left - wall.lower_left;
        let centre = wall.lower_left + 0.5 * (u + v);
        let mut worst = 0f32;
        for &(n, eye, clip_from_world) in &drawn {
            assert_eq!(eye, moving_eye(n));
            let points = [
                wall.lower_left,
                wall.lower_right,
                wall.upper_left,
                wall.lower_left + u + v,
                wall.lower_left + 0.3 * u + 0.7 * v,
                eye + 0.5 * (centre - eye),
                eye + 2.5 * (centre + 0.2 * u - eye),
            ];
            for p in points {
                let ours = clip_from_world.project_point3(p).truncate();
                let expected = ndc_through_wall(wall, eye, p);
                let e = ours.distance(expected);
                worst = worst.max(e);
                assert!(
                    e <= 1e-4,
                    "{name}, frame {n}: {p:?} drawn at {ours:?}, the eye's ray crosses the wall at {expected:?}"
                );
            }
        }
        eprintln!(
            "{name}: {} frames, worst NDC error {worst:.2e}",
            drawn.len()
        );
        match name {
            "front" => {
                seam_rows.push(bright_row(&image, N - 1).expect("strip at the front's right edge"))
            }
            "right" => {
                seam_rows.push(bright_row(&image, 0).expect("strip at the right's left edge"))
            }
            _ => {}
        }
    }
    let expected = (1.0 - SEAM_T) * N as f32;
    eprintln!(
        "seam strip: front row {:.2}, right row {:.2}, expected {expected:.2}",
        seam_rows[0], seam_rows[1]
    );
    for row in &seam_rows {
        assert!((row - expected).abs() <= 0.5, "{seam_rows:?} vs {expected}");
    }
}

/// A wall that is not a rectangle is refused by name in its view's
/// `CaveViewStatus` (the camera keeps its last projection); a good wall's
/// status is clear, and mending the wall clears the refusal.
#[test]
fn a_refused_wall_says_why_in_its_status() {
    use optica_foveated_lod::CaveViewStatus;
    let mut app = super::cpu_app();
    let good = WallRect::front_right_floor(3.0).unwrap()[0];
    let bad = WallRect {
        upper_left: good.lower_right,
        ..good
    };
    let good_view = app
        .world_mut()
        .spawn(CaveView::new(good, Eye::Cyclopean))
        .id();
    let bad_view = app.world_mut().spawn(CaveView::new(bad, Eye::Cyclopean)).id();
    for _ in 0..3 {
        app.update();
    }
    let status = |app: &App, e| app.world().get::<CaveViewStatus>(e).cloned().expect("status");
    assert_eq!(status(&app, good_view).error, None);
    let refused = status(&app, bad_view).error;
    assert!(refused.is_some(), "{refused:?}");
    app.world_mut()
        .get_mut::<CaveView>(bad_view)
        .expect("view")
        .wall = good;
    app.update();
    assert_eq!(status(&app, bad_view).error, None);
}
