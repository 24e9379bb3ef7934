//! Stiff cases for the vertex projection: a huge ground plane behind a 180°
//! dome and around a 250° one (whose antipode lies in it), refined from the
//! view or split once (unclipped), tilt 90°, a NaN vertex, tiny triangles at
//! the zenith, lines with a NaN end, through the viewer and behind it. No
//! NaN pixel, no panic, and no wrap-around: geometry appears only where its
//! directions do.

use bevy::asset::RenderAssetUsages;
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use optica_dome::{DomeApparentSize, DomeCamera, DomePlugin, DomeStatus, Error};
use optica_harness::{Headless, RenderedFrame};

use super::{dome_camera, flat};

const SIZE: u32 = 96;

/// A triangle with a NaN corner and a good one 5 units above the camera.
fn nan_mesh() -> Mesh {
    Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    )
    .with_inserted_attribute(
        Mesh::ATTRIBUTE_POSITION,
        vec![
            [f32::NAN, 5.0, 0.0],
            [1.0, 5.0, 0.0],
            [0.0, 5.0, 1.0],
            [-0.5, 5.0, -0.5],
            [0.5, 5.0, -0.5],
            [0.0, 5.0, 0.5],
        ],
    )
    .with_inserted_indices(Indices::U32(vec![0, 1, 2, 3, 4, 5]))
}

/// Red lines relative to a camera at the origin: one with a NaN end, one
/// through the viewer, one passing 1 unit under it.
fn bad_lines() -> Mesh {
    optica_dome::lines::segments(&[
        [Vec3::new(f32::NAN, 3.0, 0.0), Vec3::new(1.0, 3.0, 0.0)],
        [Vec3::new(-1.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0)],
        [Vec3::new(0.0, -1.0, -1.0), Vec3::new(0.0, -1.0, 1.0)],
    ])
}

/// The hazards every stiff scene has: a ground plane 1e5 wide (green) of
/// apparent size `ground`, the bad lines (red) round a viewer 1.6 above it
/// and a NaN triangle beside a good one 5 up (red).
fn spawn_hazards(
    commands: &mut Commands,
    meshes: &mut Assets<Mesh>,
    materials: &mut Assets<StandardMaterial>,
    ground: DomeApparentSize,
) {
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(1e5, 1e5))),
        flat(materials, Color::srgb(0.0, 1.0, 0.0)),
        ground,
    ));
    commands.spawn((
        Mesh3d(meshes.add(bad_lines())),
        flat(materials, Color::srgb(1.0, 0.0, 0.0)),
        Transform::from_xyz(0.0, 1.6, 0.0),
    ));
    commands.spawn((
        Mesh3d(meshes.add(nan_mesh())),
        flat(materials, Color::srgb(1.0, 0.0, 0.0)),
    ));
}

/// A zenith-looking dome camera 1.6 above a ground plane 1e5 wide (green)
/// of apparent size `ground`, a NaN triangle beside a good one overhead
/// (red), the bad lines (red) and 400 tiny triangles (0.5 mm) at the
/// zenith (blue).
fn render(dome: DomeCamera) -> RenderedFrame {
    render_with(dome, DomeApparentSize::Changing)
}

fn render_with(dome: DomeCamera, ground: DomeApparentSize) -> RenderedFrame {
    Headless::new(SIZE, SIZE)
        .hdr(true)
        .render(move |app: &mut App| {
            app.add_plugins(DomePlugin);
            app.add_systems(
                Startup,
                move |mut commands: Commands,
                      mut meshes: ResMut<Assets<Mesh>>,
                      mut materials: ResMut<Assets<StandardMaterial>>| {
                    spawn_hazards(&mut commands, &mut meshes, &mut materials, ground);
                    commands.spawn((
                        Mesh3d(
                            meshes.add(Plane3d::default().mesh().size(0.01, 0.01).subdivisions(19)),
                        ),
                        flat(&mut materials, Color::srgb(0.0, 0.0, 1.0)),
                        Transform::from_xyz(0.0, 50.0, 0.0),
                    ));
                    commands.spawn(dome_camera(
                        dome,
                        Transform::from_xyz(0.0, 1.6, 0.0).looking_to(Vec3::Y, Vec3::Z),
                    ));
                },
            );
        })
        .expect("render")
}

/// The share of red pixels (the lines, wrapped or streaking) among those
/// in `band` of rim radii.
fn red_share(frame: &RenderedFrame, band: std::ops::Range<f32>) -> f32 {
    let img = frame.hdr().expect("an HDR frame");
    let c = SIZE as f32 / 2.0;
    let (mut red, mut n) = (0usize, 0usize);
    for (x, y, p) in img.enumerate_pixels() {
        let r = (Vec2::new(x as f32 + 0.5, y as f32 + 0.5) - Vec2::splat(c)).length() / c;
        if band.contains(&r) {
            n += 1;
            red += usize::from(p.0[0] > 0.5 && p.0[1] < 0.5);
        }
    }
    red as f32 / n.max(1) as f32
}

/// Pixels by their distance from the centre in rim radii: (green share
/// among those in `band`).
fn green_share(
    frame: &RenderedFrame,
    band: std::ops::Range<f32>,
    keep: impl Fn(u32, u32) -> bool,
) -> (f32, usize) {
    let img = frame.hdr().expect("an HDR frame");
    assert!(
        img.as_raw().iter().all(|v| v.is_finite()),
        "a non-finite pixel"
    );
    let c = SIZE as f32 / 2.0;
    let (mut green, mut n) = (0usize, 0usize);
    for (x, y, p) in img.enumerate_pixels() {
        let r = (Vec2::new(x as f32 + 0.5, y as f32 + 0.5) - Vec2::splat(c)).length() / c;
        if band.contains(&r) && keep(x, y) {
            n += 1;
            green += usize::from(p.0[1] > 0.5 && p.0[0] < 0.5);
        }
    }
    (green as f32 / n.max(1) as f32, n)
}

#[test]
fn a_ground_behind_a_180_degree_dome_does_not_show() {
    let frame = render(DomeCamera::default());
    let (share, n) = green_share(&frame, 0.0..0.97, |_, _| true);
    assert!(n > 5000);
    assert_eq!(
        share, 0.0,
        "the ground behind the view plane shows on {share} of the disk"
    );
    // The good triangle overhead and the tiny ones at the zenith are drawn.
    let img = frame.hdr().unwrap();
    let centre = img.get_pixel(SIZE / 2, SIZE / 2).0;
    assert!(
        centre[0] > 0.5 || centre[2] > 0.5,
        "nothing at the zenith: {centre:?}"
    );
}

/// The lines with a NaN end, through the viewer and under it leave no
/// streak: nothing red away from the triangle overhead (within 0.25 of
/// the rim radius), at 180° and 250°.
#[test]
fn bad_lines_leave_no_streak() {
    for fov_deg in [180.0, 250.0] {
        let frame = render(DomeCamera {
            fov_deg,
            ..default()
        });
        let red = red_share(&frame, 0.3..0.97);
        assert_eq!(red, 0.0, "{fov_deg}°: red on {red} of the disk");
    }
}

/// The huge ground split once (the paper's pre-subdivided class: not
/// clipped; the vertex shader drops what lies near the antipode, under the
/// viewer): still behind a 180° dome, a ring round a 250° one, no wrap.
#[test]
fn a_ground_split_once_stays_where_it_belongs() {
    let behind = render_with(DomeCamera::default(), DomeApparentSize::NearlyConstant);
    let (share, _) = green_share(&behind, 0.0..0.97, |_, _| true);
    assert_eq!(share, 0.0, "the ground behind a 180° dome shows on {share}");
    let wide = render_with(
        DomeCamera {
            fov_deg: 250.0,
            ..default()
        },
        DomeApparentSize::NearlyConstant,
    );
    let (inner, _) = green_share(&wide, 0.0..0.68, |_, _| true);
    let (ring, n) = green_share(&wide, 0.76..0.97, |_, _| true);
    assert_eq!(inner, 0.0, "the ground wrapped into the disk: {inner}");
    assert!(n > 1000 && ring > 0.98, "the ground ring: {ring} of {n} px");
}

#[test]
fn a_250_degree_dome_sees_the_ground_as_a_ring_without_wrapping_round() {
    let frame = render(DomeCamera {
        fov_deg: 250.0,
        ..default()
    });
    // The horizon is 90° from the zenith: 0.72 of the rim radius.
    let (inner, _) = green_share(&frame, 0.0..0.68, |_, _| true);
    let (ring, n) = green_share(&frame, 0.76..0.97, |_, _| true);
    assert_eq!(
        inner, 0.0,
        "the ground (and its antipode) wrapped into the disk: {inner}"
    );
    assert!(n > 1000 && ring > 0.98, "the ground ring: {ring} of {n} px");
}

#[test]
fn a_dome_tilted_90_degrees_sees_the_horizon_across_its_middle() {
    let frame = render(DomeCamera {
        tilt_deg: 90.0,
        ..default()
    });
    let half = SIZE / 2;
    let (above, _) = green_share(&frame, 0.0..0.95, |_, y| y + 2 < half);
    let (below, n) = green_share(&frame, 0.0..0.95, |_, y| y > half + 2);
    assert_eq!(above, 0.0, "ground above the horizon: {above}");
    assert!(
        n > 1000 && below > 0.98,
        "ground below the horizon: {below} of {n} px"
    );
}

/// The cube-map mode on the same stiff scene: the ground stays behind a
/// 180° dome, makes a ring round a 250° one with no wrap-around, and lies
/// below the horizon at tilt 90°; no non-finite pixel. A face size the
/// mode cannot take is refused (no face camera, no panic).
#[test]
fn the_cube_mode_on_the_stiff_scene() {
    let cube = |fov_deg: f32, tilt_deg: f32, face_px: u32| DomeCamera {
        fov_deg,
        tilt_deg,
        mode: optica_dome::DomeMode::CubeMap { face_px },
        ..default()
    };
    let (behind, _) = green_share(&render(cube(180.0, 0.0, 64)), 0.0..0.97, |_, _| true);
    assert_eq!(behind, 0.0, "the ground behind a 180° cube dome: {behind}");
    let wide = render(cube(250.0, 0.0, 64));
    let (inner, _) = green_share(&wide, 0.0..0.68, |_, _| true);
    let (ring, n) = green_share(&wide, 0.76..0.97, |_, _| true);
    assert_eq!(inner, 0.0, "the ground wrapped into the disk: {inner}");
    assert!(n > 1000 && ring > 0.98, "the ground ring: {ring} of {n} px");
    let tilted = render(cube(180.0, 90.0, 64));
    let half = SIZE / 2;
    let (above, _) = green_share(&tilted, 0.0..0.95, |_, y| y + 2 < half);
    let (below, n) = green_share(&tilted, 0.0..0.95, |_, y| y > half + 2);
    assert_eq!(above, 0.0, "ground above the horizon: {above}");
    assert!(n > 1000 && below > 0.98, "ground below: {below} of {n} px");
    let refused = cube(180.0, 0.0, 4).validate();
    assert!(
        matches!(&refused, Err(Error::Setting(e)) if e.what == "cube face size (px)" && e.value == 4.0),
        "{refused:?}"
    );
    // Refused: the camera keeps Bevy's projection, and nothing breaks.
    let refused = render(cube(180.0, 0.0, 4));
    green_share(&refused, 0.0..1.0, |_, _| true);
}

/// Every lens on the stiff scene: behind a 180° dome the ground does not
/// show and the bad lines leave no streak; round a 250° one the ground is
/// a ring outside the horizon's circle (where each lens puts 90°), with no
/// wrap-around; at the widest field of view each lens takes (350°, 180°
/// for the orthographic) nothing wraps into the horizon's circle and no
/// pixel is non-finite. A lens the field of view cannot take (an
/// orthographic 200°, a polynomial that folds back) is refused, and the
/// app keeps running.
#[test]
fn every_lens_on_the_stiff_scene() {
    use optica_dome::{DomeLens, MAX_FOV_DEG};
    use optica_optics::glam::DVec3;
    for lens in DomeLens::FISHEYES {
        let camera = |fov_deg: f32| DomeCamera {
            fov_deg,
            lens,
            ..default()
        };
        let name = lens.name();
        let behind = render(camera(180.0));
        let (share, _) = green_share(&behind, 0.0..0.97, |_, _| true);
        assert_eq!(share, 0.0, "{name}: the ground behind a 180° dome shows");
        let red = red_share(&behind, 0.3..0.97);
        assert_eq!(red, 0.0, "{name}: red on {red} of the disk");
        if lens == DomeLens::Orthographic {
            continue;
        }
        for fov_deg in [250.0, MAX_FOV_DEG] {
            // Where this lens puts the horizon (90° from the zenith).
            let dome = camera(fov_deg).projection(SIZE).expect("a valid dome");
            let horizon = dome
                .project(DVec3::X)
                .image_point()
                .map(|p| ((p.pixel - dome.centre_px()).length() / dome.rim_radius_px()) as f32)
                .expect("the horizon projects");
            let frame = render(camera(fov_deg));
            let (inner, _) = green_share(&frame, 0.0..horizon - 0.05, |_, _| true);
            assert_eq!(inner, 0.0, "{name} {fov_deg}°: the ground wrapped in");
            if fov_deg == 250.0 {
                let (ring, n) = green_share(&frame, horizon + 0.05..0.97, |_, _| true);
                assert!(
                    n > 500 && ring > 0.98,
                    "{name} {fov_deg}°: the ground ring {ring} of {n} px (horizon at {horizon:.2})"
                );
            }
        }
    }
    for refused in [
        DomeCamera {
            fov_deg: 200.0,
            lens: DomeLens::Orthographic,
            ..default()
        },
        DomeCamera {
            fov_deg: 200.0,
            lens: DomeLens::Polynomial {
                k: [1.0, -0.2, 0.0, 0.0],
            },
            ..default()
        },
    ] {
        let why = refused.validate().expect_err("refused");
        assert!(
            matches!(&why, Error::Lens { lens, .. } if *lens == refused.lens.name()),
            "{why:?}"
        );
        green_share(&render(refused), 0.0..1.0, |_, _| true);
    }
}

/// The stiff scene for the equirectangular panorama (192 × 96, looking at
/// the horizon): the ground 1e5 wide fills every row below the horizon,
/// across the seam and down to the nadir's row, and nothing above it; a
/// plane overhead with a vertex exactly on the north pole fills the top
/// quarter, and a red triangle around the pole (beside a NaN one) the
/// whole top row; the line passing under the viewer through the nadir is
/// two meridians (the image centre's and the seam's) and leaves no
/// streak; no pixel is non-finite.
#[test]
fn the_panorama_on_the_stiff_scene() {
    use optica_dome::DomeLens;
    let (w, h) = (192u32, 96u32);
    let frame = Headless::new(w, h)
        .hdr(true)
        .render(move |app: &mut App| {
            app.add_plugins(DomePlugin);
            app.add_systems(
                Startup,
                move |mut commands: Commands,
                      mut meshes: ResMut<Assets<Mesh>>,
                      mut materials: ResMut<Assets<StandardMaterial>>| {
                    spawn_hazards(
                        &mut commands,
                        &mut meshes,
                        &mut materials,
                        DomeApparentSize::Changing,
                    );
                    // 20 × 20 at 10 up: a vertex right above the camera.
                    commands.spawn((
                        Mesh3d(
                            meshes.add(Plane3d::default().mesh().size(20.0, 20.0).subdivisions(3)),
                        ),
                        flat(&mut materials, Color::srgb(0.0, 0.0, 1.0)),
                        Transform::from_xyz(0.0, 11.6, 0.0),
                    ));
                    commands.spawn(dome_camera(
                        DomeCamera {
                            lens: DomeLens::Equirectangular,
                            ..default()
                        },
                        Transform::from_xyz(0.0, 1.6, 0.0).looking_to(Vec3::NEG_Z, Vec3::Y),
                    ));
                },
            );
        })
        .expect("render");
    let img = frame.hdr().expect("an HDR frame");
    assert!(
        img.as_raw().iter().all(|v| v.is_finite()),
        "a non-finite pixel"
    );
    let colour = |x: u32, y: u32| {
        let p = img.get_pixel(x, y).0;
        (p[0] > 0.5, p[1] > 0.5, p[2] > 0.5)
    };
    let (mut stray_red, mut line_red) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            let (r, g, b) = colour(x, y);
            if y == 0 {
                assert!(
                    r && !g && !b,
                    "the pole's row at {x} is not the red triangle"
                );
            } else if y < h / 4 - 1 {
                assert!(r || b, "({x}, {y}) under the overhead plane is empty");
            }
            // The plane's corners reach down to 35° of latitude (row 29).
            if (h / 2 - 15..h / 2 - 1).contains(&y) {
                assert!(!r && !g && !b, "({x}, {y}) above the horizon is not empty");
            }
            let near = |c: u32| x.abs_diff(c) <= 2;
            if y > h / 2 + 1 {
                if r && !g {
                    if near(w / 2) || near(0) || near(w - 1) {
                        line_red += 1;
                    } else {
                        stray_red += 1;
                    }
                } else {
                    assert!(g, "({x}, {y}) below the horizon is not ground");
                }
            }
        }
    }
    assert_eq!(stray_red, 0, "red off the line's meridians");
    assert!(
        line_red > 20,
        "the line under the viewer is missing ({line_red} px)"
    );
}

/// Each dome camera's [`DomeStatus`] says what became of it: a valid
/// vertex-mode camera has Bevy's view shader patched and no error; a
/// refused one names the refusal (and keeps drawing its last projection,
/// here Bevy's own); a cube-mode camera needs no patch but is told it.
#[test]
fn the_status_says_whether_the_projection_took() {
    use std::sync::{Arc, Mutex};
    let seen = Arc::new(Mutex::new(Vec::<(String, DomeStatus)>::new()));
    let log = seen.clone();
    Headless::new(32, 32)
        .render(move |app: &mut App| {
            app.add_plugins(DomePlugin);
            app.add_systems(Startup, |mut commands: Commands| {
                let up = Transform::from_xyz(0.0, 1.6, 0.0).looking_to(Vec3::Y, Vec3::Z);
                for (name, dome, order) in [
                    ("valid", DomeCamera::default(), 0),
                    (
                        "refused",
                        DomeCamera {
                            near: -1.0,
                            ..default()
                        },
                        1,
                    ),
                    (
                        "cube",
                        DomeCamera {
                            mode: optica_dome::DomeMode::CubeMap { face_px: 32 },
                            ..default()
                        },
                        2,
                    ),
                ] {
                    commands
                        .spawn((Name::new(name), dome_camera(dome, up)))
                        .insert(Camera { order, ..default() });
                }
            });
            app.add_systems(Last, move |cameras: Query<(&Name, &DomeStatus)>| {
                *log.lock().expect("log") = cameras
                    .iter()
                    .map(|(n, s)| (n.to_string(), s.clone()))
                    .collect();
            });
        })
        .expect("render");
    let seen = seen.lock().expect("log").clone();
    let status = |name: &str| {
        seen.iter()
            .find(|(n, _)| n == name)
            .map(|(_, s)| s.clone())
            .expect(name)
    };
    assert_eq!(
        status("valid"),
        DomeStatus {
            vertex_projection: Some(true),
            error: None
        }
    );
    let refused = status("refused");
    assert!(
        matches!(&refused.error, Some(Error::Setting(e)) if e.what == "near distance" && e.value == -1.0),
        "{refused:?}"
    );
    assert_eq!(status("cube").error, None);
    // Bevy's shader text without the lines the patch goes into: refused by
    // name, which the status would carry for every vertex-mode camera.
    assert_eq!(
        optica_dome::hooks::patched("fn main() {}"),
        Err(Error::ShaderPatch("#import bevy_pbr::prepass_bindings"))
    );
    // Bevy's fragment library without the function the exact-attribute
    // step goes into: its own error, which names the line.
    assert_eq!(
        optica_dome::hooks::patched_fragment("#import bevy_pbr::{\n    pbr_types,\n}"),
        Err(Error::AttributePatch(
            "fn pbr_input_from_standard_material(\n    in: VertexOutput,"
        ))
    );
}

/// The vertex mode's twins are a Bevy relationship users can filter out:
/// with one dome camera each scene mesh has one twin in its
/// `DomeTwinEntities`, and `Query<&Mesh3d, NotDomeHelper>` sees the scene's
/// meshes alone.
#[test]
fn twins_are_a_relationship_that_users_can_filter_out() {
    use optica_dome::{DomeTwinEntities, NotDomeHelper};
    use std::sync::{Arc, Mutex};
    let counts = Arc::new(Mutex::new((0, 0, Vec::new())));
    let log = counts.clone();
    Headless::new(32, 32)
        .frames(3)
        .render(move |app: &mut App| {
            app.add_plugins(DomePlugin);
            app.add_systems(
                Startup,
                |mut commands: Commands,
                 mut meshes: ResMut<Assets<Mesh>>,
                 mut materials: ResMut<Assets<StandardMaterial>>| {
                    for x in [-1.0, 1.0] {
                        commands.spawn((
                            Mesh3d(meshes.add(Plane3d::default().mesh().size(1.0, 1.0))),
                            flat(&mut materials, Color::srgb(0.0, 1.0, 0.0)),
                            Transform::from_xyz(x, 3.0, 0.0),
                        ));
                    }
                    commands.spawn(dome_camera(
                        DomeCamera::default(),
                        Transform::from_xyz(0.0, 1.6, 0.0).looking_to(Vec3::Y, Vec3::Z),
                    ));
                },
            );
            app.add_systems(
                Last,
                move |all: Query<&Mesh3d>,
                      ours: Query<&Mesh3d, NotDomeHelper>,
                      twins: Query<&DomeTwinEntities>| {
                    *log.lock().expect("log") = (
                        all.iter().count(),
                        ours.iter().count(),
                        twins.iter().map(|t| t.len()).collect::<Vec<_>>(),
                    );
                },
            );
        })
        .expect("render");
    let (all, ours, twins) = counts.lock().expect("log").clone();
    assert_eq!(ours, 2, "the scene's meshes");
    assert_eq!(twins, vec![1, 1], "one twin per mesh and camera");
    assert_eq!(all, 4, "meshes and their twins");
}

/// A tolerance below a hundredth of a pixel is refused by name: the
/// triangles grow as its inverse (a 90° triangle on a 64 px dome is 6.5
/// million triangles at 10⁻⁶ px, a minute of refinement), which random
/// accepted settings drawn at 32² found as an app that stopped and grew
/// by gigabytes. The floor itself is accepted.
#[test]
fn a_tolerance_finer_than_the_floor_is_refused_by_name() {
    use optica_dome::MIN_TOLERANCE_PX;
    for bad in [1e-6, 1e-3, 0.009] {
        let refused = DomeCamera {
            tolerance_px: bad,
            ..default()
        }
        .validate();
        assert!(
            matches!(&refused, Err(Error::Setting(e)) if e.what == "tolerance (px)" && e.value == f64::from(bad)),
            "{refused:?}"
        );
    }
    let floor = DomeCamera {
        tolerance_px: MIN_TOLERANCE_PX,
        ..default()
    };
    assert_eq!(floor.validate(), Ok(()));
}
