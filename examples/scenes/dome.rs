//! The dome scene: a planetarium domemaster — a starry sky turning about
//! the pole with constellation lines, an altitude–azimuth graticule, and a
//! landscape with large buildings near the horizon (big triangles at the
//! rim), seen by a slowly turning fisheye dome camera.

// Each example uses part of this file; the showcase uses all of it.
#![allow(dead_code)]

use bevy::prelude::*;
use optica::dome::lines::{self, Graticule};
use optica::dome::{DomeApparentSize, DomeCamera, DomeLens, DomePlugin, DomeShowClock};

use super::common::SceneEntity;

/// The scene's name in file names and on the command line.
pub const NAME: &str = "dome";
/// The domemaster's side in pixels in a window of its own.
pub const SIZE: u32 = 1024;
/// Turn rate of the camera about the zenith, radians per second of show.
const TURN: f32 = 0.1;
/// Turn rate of the sky about the celestial pole, radians per second of
/// show (a day in two minutes).
const SKY_TURN: f32 = std::f32::consts::TAU / 120.0;

/// The dome camera the scene starts with.
#[derive(Resource, Clone, Debug, Default)]
pub struct DomeScene {
    /// The camera's settings.
    pub dome: DomeCamera,
}

/// Adds the plugin and the turning of the camera and the sky (they move
/// only this scene's entities).
pub fn build(app: &mut App) {
    app.add_plugins(DomePlugin)
        .init_resource::<DomeScene>()
        .add_systems(Update, (turn, turn_sky));
}

/// The image for `dome` at `size` px across: square for a fisheye, 2:1 for
/// the panorama.
pub fn target_size(dome: &DomeCamera, size: u32) -> (u32, u32) {
    match dome.lens {
        DomeLens::Equirectangular => (size, size / 2),
        _ => (size, size),
    }
}

/// How the camera is mounted: a fisheye looks at the zenith, the audience
/// facing −Z; the panorama looks at the horizon (−Z) with +Y up.
pub fn mount(dome: &DomeCamera) -> Quat {
    match dome.lens {
        DomeLens::Equirectangular => Transform::IDENTITY.looking_to(Vec3::NEG_Z, Vec3::Y),
        _ => Transform::IDENTITY.looking_to(Vec3::Y, Vec3::Z),
    }
    .rotation
}

/// In a window, the show clock follows real time.
pub fn run_show_clock(time: Res<Time>, mut clock: ResMut<DomeShowClock>) {
    clock.frame = (time.elapsed_secs() * clock.fps) as u32;
}

/// A small deterministic generator, so the sky is the same on every run.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// A direction at altitude `alt` and azimuth `az` (radians; azimuth 0 is
/// −Z, the audience front).
fn sky_dir(alt: f32, az: f32) -> Vec3 {
    Vec3::new(alt.cos() * az.sin(), alt.sin(), -alt.cos() * az.cos())
}

/// The sky: stars and constellation lines, turning about the celestial
/// pole with the show clock (diurnal motion) around the viewer.
#[derive(Component)]
struct Sky;

/// The celestial pole seen from latitude 35° north, the audience facing
/// south (−Z): 35° above the northern horizon (+Z).
fn pole() -> Vec3 {
    let lat = 35f32.to_radians();
    Vec3::new(0.0, lat.sin(), lat.cos())
}

pub fn spawn(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    scene: Res<DomeScene>,
) {
    let dome = scene.dome;
    commands.insert_resource(GlobalAmbientLight {
        color: Color::srgb(0.5, 0.6, 0.9),
        brightness: 120.0,
        ..default()
    });
    let mut glow = |c: Color| {
        materials.add(StandardMaterial {
            base_color: c,
            unlit: true,
            ..default()
        })
    };
    let (star, line, grid) = (
        glow(Color::srgb(1.0, 0.97, 0.9)),
        glow(Color::srgb(0.35, 0.55, 1.0)),
        glow(Color::srgb(0.6, 0.25, 0.25)),
    );
    let sky = commands
        .spawn((SceneEntity, Sky, Transform::IDENTITY, Visibility::default()))
        .id();
    // Stars: small cubes 300 units out over the whole sphere (the ground
    // hides those below the horizon), one mesh. Their apparent size never
    // changes (they keep their distance and only turn about the viewer):
    // the paper's pre-subdivided class, split once and never again.
    const R: f32 = 300.0;
    let mut rng = Lcg(0x5EED);
    let mut stars = Vec::new();
    let mut field: Option<Mesh> = None;
    for _ in 0..1200 {
        let alt = (2.0 * rng.next() - 1.0).asin();
        let az = rng.next() * std::f32::consts::TAU;
        let size = 0.4 + 1.6 * rng.next().powi(4);
        let p = R * sky_dir(alt, az);
        stars.push(p);
        let cube = Mesh::from(Cuboid::from_length(size)).translated_by(p);
        match field.as_mut() {
            Some(f) => f.merge(&cube).expect("cubes share their attributes"),
            None => field = Some(cube),
        }
    }
    if let Some(field) = field {
        commands.spawn((
            SceneEntity,
            Mesh3d(meshes.add(field)),
            MeshMaterial3d(star),
            DomeApparentSize::NearlyConstant,
            ChildOf(sky),
        ));
    }
    // Constellation lines: chains of nearby stars, one line mesh. A
    // segment between two stars on the sphere is seen along the great
    // circle through them; the dome refines it into that exact arc.
    let mut pairs = Vec::new();
    for k in 0..80 {
        let (a, b, c) = (stars[k * 7], stars[k * 7 + 1], stars[k * 7 + 2]);
        pairs.extend(
            [[a, b], [b, c]]
                .into_iter()
                .filter(|[p, q]| p.distance(*q) < 0.6 * R),
        );
    }
    commands.spawn((
        SceneEntity,
        Mesh3d(meshes.add(lines::segments(&pairs))),
        MeshMaterial3d(line),
        ChildOf(sky),
    ));
    // The altitude–azimuth graticule, fixed to the horizon.
    commands.spawn((
        SceneEntity,
        Mesh3d(
            meshes.add(
                Graticule {
                    radius: 0.9 * R,
                    altitude_step_deg: 30.0,
                    azimuth_step_deg: 45.0,
                    ..default()
                }
                .mesh(),
            ),
        ),
        MeshMaterial3d(grid),
    ));
    // The landscape: a ground plane and large buildings near the horizon.
    commands.spawn((
        SceneEntity,
        Mesh3d(meshes.add(Plane3d::default().mesh().size(2000.0, 2000.0))),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::srgb(0.12, 0.16, 0.1),
            perceptual_roughness: 0.9,
            ..default()
        })),
        Transform::from_xyz(0.0, -1.6, 0.0),
    ));
    let building = materials.add(StandardMaterial {
        base_color: Color::srgb(0.35, 0.33, 0.3),
        perceptual_roughness: 0.8,
        ..default()
    });
    for (i, (w, h)) in [
        (30.0, 25.0),
        (18.0, 45.0),
        (40.0, 15.0),
        (22.0, 30.0),
        (15.0, 60.0),
    ]
    .into_iter()
    .enumerate()
    {
        let az = (i as f32 * 72.0 + 20.0).to_radians();
        let p = 120.0 * sky_dir(0.0, az);
        commands.spawn((
            SceneEntity,
            Mesh3d(meshes.add(Cuboid::new(w, h, w))),
            MeshMaterial3d(building.clone()),
            Transform::from_xyz(p.x, h / 2.0 - 1.6, p.z),
        ));
    }
    commands.spawn((
        SceneEntity,
        DirectionalLight {
            illuminance: 1_500.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(-1.0, 2.0, 0.5).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    // The dome: a fisheye at the zenith, the audience facing −Z (or the
    // panorama looking at the horizon).
    commands.spawn((
        SceneEntity,
        dome,
        Camera {
            clear_color: ClearColorConfig::Custom(Color::srgb(0.01, 0.015, 0.04)),
            ..default()
        },
        Transform::from_rotation(mount(&dome)),
    ));
}

/// Turns the dome camera about the zenith with the show clock (the twins
/// follow: refined again as the scene moves relative to the camera).
fn turn(clock: Res<DomeShowClock>, mut cameras: Query<(&mut Transform, &DomeCamera)>) {
    for (mut transform, dome) in &mut cameras {
        transform.rotation = Quat::from_rotation_y(TURN * clock.seconds()) * mount(dome);
    }
}

/// Turns the sky about the celestial pole with the show clock: the stars
/// (pre-subdivided) keep their twin, the constellation lines are refined
/// again.
fn turn_sky(clock: Res<DomeShowClock>, mut skies: Query<&mut Transform, With<Sky>>) {
    for mut transform in &mut skies {
        transform.rotation = Quat::from_axis_angle(pole(), SKY_TURN * clock.seconds());
    }
}

