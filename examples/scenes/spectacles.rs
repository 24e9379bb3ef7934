//! The spectacles scene: a room seen through an eye — a book at 30 cm on
//! the table, an eye chart of tumbling Es on the wall 5 m away — for the
//! paper's Fig. 8 cases and everyday eyes, with and without their glasses.

// Each example uses part of this file; the showcase uses all of it.
#![allow(dead_code)]

use bevy::asset::RenderAssetUsages;
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
use optica::spectacles::presets::{Preset, presets};
use optica::spectacles::{
    CloneDefocus, CurvedMirror, MirrorMethod, MirrorViewer, SpectaclesPlugin,
};

use super::common::SceneEntity;

/// The scene's name in file names and on the command line.
pub const NAME: &str = "spectacles";
/// The picture's size in a window of its own.
pub const SIZE: (u32, u32) = (800, 600);
/// Where the eye is: seated, 1.2 m above the floor.
pub const EYE: Vec3 = Vec3::new(0.0, 1.2, 0.0);
pub const CHART_M: f32 = 5.0;
pub const BOOK_M: f32 = 0.3;
/// Where the book lies from the eye: below, in front, where a reader holds
/// it (looked at through a progressive lens's near zone).
pub const BOOK: Vec3 = Vec3::new(0.0, -0.17, -0.24);
/// Where the eye camera looks: the chart, a little down.
pub const LOOK_AT: Vec3 = Vec3::new(0.0, EYE.y - 0.25, -CHART_M);

/// Degrees from the camera's line of sight down to the book.
pub fn book_down_deg() -> f64 {
    let ahead = (LOOK_AT - EYE).normalize();
    f64::from(ahead.angle_between(BOOK.normalize()).to_degrees())
}

/// What the scene starts with: the eye (and its glasses) and a mirror.
#[derive(Resource, Clone, Debug)]
pub struct SpectaclesScene {
    /// The eye and its glasses.
    pub preset: Preset,
    /// A convex safety mirror on the left wall, drawn this way.
    pub mirror: Option<MirrorMethod>,
}

impl Default for SpectaclesScene {
    /// The first preset, no mirror.
    fn default() -> Self {
        Self {
            preset: presets().remove(0),
            mirror: None,
        }
    }
}

/// Adds the plugin.
pub fn build(app: &mut App) {
    app.add_plugins(SpectaclesPlugin)
        .init_resource::<SpectaclesScene>();
}

/// A tumbling-E chart: rows of Es from 50′ down to 5′ tall at 5 m (a
/// 20/20 row last), on a 1 m × 1 m board, 1,024² texels (~1 mm each).
fn eye_chart() -> Image {
    let n = 1024usize;
    let mut px = vec![250u8; n * n];
    // Letter heights (m) at 5 m: 5·tan(k′).
    let rows = [50.0f32, 40.0, 30.0, 20.0, 15.0, 10.0, 7.5, 5.0];
    let mut y = 40usize;
    for (r, arcmin) in rows.iter().enumerate() {
        let h = ((CHART_M * (arcmin / 60.0).to_radians().tan()) * n as f32)
            .round()
            .max(5.0) as usize;
        let count = (n / (2 * h)).min(8);
        let left = (n - count * 2 * h + h) / 2;
        for c in 0..count {
            let x0 = left + c * 2 * h;
            let turn = (r * 3 + c * 5) % 4;
            let stroke = (h / 5).max(1);
            for dy in 0..h {
                for dx in 0..h {
                    // An E opening to the right, then turned.
                    let (u, v) = match turn {
                        0 => (dx, dy),
                        1 => (dy, h - 1 - dx),
                        2 => (h - 1 - dx, h - 1 - dy),
                        _ => (h - 1 - dy, dx),
                    };
                    let band = v / stroke;
                    let ink = u < stroke || band.is_multiple_of(2);
                    if ink && y + dy < n && x0 + dx < n {
                        px[(y + dy) * n + x0 + dx] = 15;
                    }
                }
            }
        }
        y += h + h / 2 + 10;
    }
    grey_image(n, &px)
}

/// A book page: lines of word-like blocks, 8 pt type at 30 cm (~1.2 mm
/// x-height, 14′).
fn page() -> Image {
    let n = 512usize;
    let mut px = vec![238u8; n * n];
    let mut seed = 7u32;
    let mut rand = || {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        seed >> 16
    };
    let (line, x_height) = (18usize, 7usize);
    for l in 0..(n / line - 2) {
        let y = line + l * line;
        let mut x = 24usize;
        while x < n - 40 {
            let word = 10 + (rand() % 40) as usize;
            for dy in 0..x_height {
                for dx in 0..word.min(n - 24 - x) {
                    if (dx % 5) != 4 {
                        px[(y + dy) * n + x + dx] = 30;
                    }
                }
            }
            x += word + 8;
        }
    }
    grey_image(n, &px)
}

fn grey_image(n: usize, px: &[u8]) -> Image {
    let data: Vec<u8> = px.iter().flat_map(|&v| [v, v, v, 255]).collect();
    Image::new(
        Extent3d {
            width: n as u32,
            height: n as u32,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        data,
        TextureFormat::Rgba8UnormSrgb,
        RenderAssetUsages::RENDER_WORLD,
    )
}

/// A flat quad of `size`, finely split (each vertex carries its own blur:
/// the paper's §6.1), facing +Z.
fn board(size: Vec2, split: u32) -> Mesh {
    Plane3d::new(Vec3::Z, 0.5 * size)
        .mesh()
        .subdivisions(split)
        .build()
}

pub fn spawn(
    mut commands: Commands,
    start: Res<SpectaclesScene>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut images: ResMut<Assets<Image>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    commands.insert_resource(GlobalAmbientLight {
        color: Color::srgb(0.95, 0.92, 0.85),
        brightness: 600.0,
        ..default()
    });
    let wall = materials.add(StandardMaterial {
        base_color: Color::srgb(0.82, 0.8, 0.74),
        perceptual_roughness: 0.9,
        ..default()
    });
    let back_wall = materials.add(StandardMaterial {
        base_color: Color::srgb(0.35, 0.45, 0.6),
        perceptual_roughness: 0.9,
        ..default()
    });
    let wood = materials.add(StandardMaterial {
        base_color: Color::srgb(0.45, 0.3, 0.18),
        perceptual_roughness: 0.6,
        ..default()
    });
    // Floor, ceiling, the back wall just behind the chart, side walls.
    commands.spawn((
        SceneEntity,
        Mesh3d(
            meshes.add(
                Plane3d::new(Vec3::NEG_Y, Vec2::new(3.0, 3.2))
                    .mesh()
                    .subdivisions(24),
            ),
        ),
        MeshMaterial3d(wall.clone()),
        Transform::from_xyz(0.0, 2.6, -2.8),
    ));
    commands.spawn((
        SceneEntity,
        Mesh3d(
            meshes.add(
                Plane3d::new(Vec3::Y, Vec2::new(3.0, 3.2))
                    .mesh()
                    .subdivisions(24),
            ),
        ),
        MeshMaterial3d(wood.clone()),
        Transform::from_xyz(0.0, 0.0, -2.8),
    ));
    commands.spawn((
        SceneEntity,
        Mesh3d(meshes.add(board(Vec2::new(6.0, 3.0), 24))),
        MeshMaterial3d(wall.clone()),
        Transform::from_xyz(0.0, 1.5, -CHART_M - 0.02),
    ));
    for side in [-1.0f32, 1.0] {
        commands.spawn((
            SceneEntity,
            Mesh3d(meshes.add(board(Vec2::new(6.0, 3.0), 32))),
            MeshMaterial3d(wall.clone()),
            Transform::from_xyz(1.8 * side, 1.5, -2.8)
                .with_rotation(Quat::from_rotation_y(-side * std::f32::consts::FRAC_PI_2)),
        ));
    }
    // The chart, centred at eye height.
    commands.spawn((
        SceneEntity,
        Mesh3d(meshes.add(board(Vec2::splat(1.0), 16))),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color_texture: Some(images.add(eye_chart())),
            perceptual_roughness: 0.8,
            ..default()
        })),
        Transform::from_xyz(0.0, EYE.y + 0.1, -CHART_M),
    ));
    // A table and the open book on it, 30 cm from the eye, tilted up.
    commands.spawn((
        SceneEntity,
        Mesh3d(meshes.add(Cuboid::new(0.9, 0.04, 0.6))),
        MeshMaterial3d(wood),
        Transform::from_xyz(0.0, 0.98, -0.4),
    ));
    commands.spawn((
        SceneEntity,
        Mesh3d(meshes.add(board(Vec2::new(0.2, 0.15), 16))),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color_texture: Some(images.add(page())),
            perceptual_roughness: 0.7,
            ..default()
        })),
        Transform::from_translation(EYE + BOOK)
            .looking_at(EYE, Vec3::Y)
            .mul_transform(Transform::from_rotation(Quat::from_rotation_y(
                std::f32::consts::PI,
            ))),
    ));
    commands.spawn((
        SceneEntity,
        DirectionalLight {
            illuminance: 4_000.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(1.5, 3.0, 1.0).looking_at(Vec3::new(0.0, 1.0, -2.5), Vec3::Y),
    ));
    let preset = start.preset.clone();
    let mut camera = commands.spawn((
        SceneEntity,
        Camera3d::default(),
        Projection::Perspective(PerspectiveProjection {
            fov: 55f32.to_radians(),
            near: 0.05,
            ..default()
        }),
        Transform::from_translation(EYE).looking_at(LOOK_AT, Vec3::Y),
        preset.eye,
        CloneDefocus::default(),
    ));
    if let Some(s) = preset.spectacles {
        camera.insert(s);
    }
    if let Some(method) = start.mirror.clone() {
        // The clones do not carry the mirror: the view is drawn sharp.
        camera.insert((
            MirrorViewer,
            CloneDefocus {
                enabled: false,
                ..default()
            },
        ));
        // The wall behind the eye, for the mirror to show, and a convex
        // safety mirror on the left wall, turned to the eye.
        commands.spawn((
            SceneEntity,
            Mesh3d(meshes.add(board(Vec2::new(6.0, 3.0), 24))),
            MeshMaterial3d(back_wall),
            Transform::from_xyz(0.0, 1.5, 0.4)
                .with_rotation(Quat::from_rotation_y(std::f32::consts::PI)),
        ));
        commands.spawn((
            SceneEntity,
            CurvedMirror {
                radius_m: 1.5,
                size_m: Vec2::new(0.6, 0.45),
                method,
                ..default()
            },
            Transform::from_xyz(-1.1, 1.45, -2.2).looking_at(EYE, Vec3::Y),
        ));
    }
}
