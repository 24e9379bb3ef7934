//! The test scenes: unlit targets (so that a pixel is the texture's colour,
//! whatever the lights) at known distances straight ahead of an eye camera.

use bevy::prelude::*;
use optica_harness::textures::{checker, gaussian_spot};
use optica_report::fixtures::clearing_camera;
use optica_spectacles::{CloneDefocus, Eye, Spectacles, SpectaclesPlugin};

/// A target: a square of `size` metres, `distance` metres straight ahead
/// of the camera at the origin (looking down −Z), facing it, showing a
/// checkerboard of `cells` cells (or plain white with `cells = 0`),
/// split into `split`² quads so that its blur varies per vertex.
#[derive(Clone, Copy, Debug)]
pub struct Target {
    pub distance: f32,
    pub size: f32,
    pub offset: Vec2,
    pub cells: u32,
    pub split: u32,
    /// A Gaussian spot instead of a checkerboard.
    pub spot: bool,
}

impl Target {
    pub fn checker(distance: f32, size: f32, cells: u32) -> Self {
        Self {
            distance,
            size,
            offset: Vec2::ZERO,
            cells,
            split: 16,
            spot: false,
        }
    }

    /// A Gaussian spot of `sigma` metres at `distance`, on a black square
    /// of eight sigma.
    pub fn spot(distance: f32, sigma: f32) -> Self {
        Self {
            split: 1,
            spot: true,
            ..Self::checker(distance, 8.0 * sigma, 0)
        }
    }
}

/// A plane mesh of `split`² quads facing +Z.
fn split_plane(size: f32, split: u32) -> Mesh {
    Plane3d::new(Vec3::Z, Vec2::splat(0.5 * size))
        .mesh()
        .subdivisions(split.saturating_sub(1))
        .build()
}

/// A scene of unlit targets seen by a camera at the origin with `eye` (and
/// `spectacles`); `None` for a plain camera. Vertical field of view `fov`
/// (rad), MSAA off.
pub fn scene(
    targets: Vec<Target>,
    eye: Option<(Eye, CloneDefocus)>,
    spectacles: Option<Spectacles>,
    fov: f32,
) -> impl FnOnce(&mut App) {
    scene_with_background(targets, eye, spectacles, fov, Color::srgb(0.5, 0.5, 0.5))
}

/// [`scene`] with the clear colour `background`.
pub fn scene_with_background(
    targets: Vec<Target>,
    eye: Option<(Eye, CloneDefocus)>,
    spectacles: Option<Spectacles>,
    fov: f32,
    background: Color,
) -> impl FnOnce(&mut App) {
    move |app: &mut App| {
        app.add_plugins(SpectaclesPlugin);
        app.add_systems(
            Startup,
            move |mut commands: Commands,
                  mut meshes: ResMut<Assets<Mesh>>,
                  mut images: ResMut<Assets<Image>>,
                  mut materials: ResMut<Assets<StandardMaterial>>| {
                for t in &targets {
                    let texture = if t.spot {
                        Some(images.add(gaussian_spot(64, 0.125)))
                    } else {
                        (t.cells > 0).then(|| images.add(checker(256, t.cells, 0, 255)))
                    };
                    let material = materials.add(StandardMaterial {
                        base_color_texture: texture,
                        unlit: true,
                        ..default()
                    });
                    commands.spawn((
                        Mesh3d(meshes.add(split_plane(t.size, t.split))),
                        MeshMaterial3d(material),
                        Transform::from_xyz(t.offset.x, t.offset.y, -t.distance),
                    ));
                }
                let mut camera = commands.spawn(clearing_camera(background, fov, 0.01));
                if let Some((eye, defocus)) = eye.clone() {
                    camera.insert((eye, defocus));
                }
                if let Some(s) = spectacles.clone() {
                    camera.insert(s);
                }
            },
        );
    }
}
