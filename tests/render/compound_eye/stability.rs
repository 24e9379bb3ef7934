//! Stiff and extreme settings: grazing and normal views, index 1, tiny and
//! huge R_t, degenerate, mirrored and stretched UVs, radius → 0, NaN
//! parameters. No NaN pixel, no panic, and the documented fallback.

use bevy::mesh::VertexAttributeValues;
use bevy::prelude::*;
use optica_compound_eye::{CompoundEye, EyeOutput};
use optica_harness::{Headless, RenderedFrame};

use super::{ortho, scene};

const SIZE: u32 = 64;

fn quad_with_uvs(map: impl Fn([f32; 2]) -> [f32; 2]) -> Mesh {
    let mut mesh = Mesh::from(Rectangle::new(2.0, 2.0));
    if let Some(VertexAttributeValues::Float32x2(uv)) = mesh.attribute_mut(Mesh::ATTRIBUTE_UV_0) {
        for t in uv.iter_mut() {
            *t = map(*t);
        }
    }
    mesh
}

fn render(mesh: Mesh, eye: Option<CompoundEye>, camera: Transform) -> RenderedFrame {
    Headless::new(SIZE, SIZE)
        .hdr(true)
        .render(scene(mesh, Transform::IDENTITY, eye, camera, ortho(2.4)))
        .expect("render")
}

fn finite(frame: &RenderedFrame) -> bool {
    frame
        .hdr()
        .is_some_and(|img| img.as_raw().iter().all(|v| v.is_finite()))
}

fn front() -> Transform {
    Transform::from_xyz(0.0, 0.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y)
}

/// 89° from the quad's normal.
fn grazing() -> Transform {
    let dir = Vec3::new(
        0.0,
        -(89f32.to_radians().sin()),
        -(89f32.to_radians().cos()),
    )
    .normalize();
    Transform::from_translation(-4.0 * dir).looking_to(dir, Vec3::Y)
}

fn pigment(eye: CompoundEye) -> Option<CompoundEye> {
    Some(CompoundEye {
        output: EyeOutput::PigmentOnly,
        ..eye
    })
}

#[test]
fn extreme_views_and_settings_give_finite_pixels() {
    let quad = || quad_with_uvs(|t| t);
    let cases: Vec<(&str, Mesh, CompoundEye, Transform)> = vec![
        ("normal view", quad(), CompoundEye::default(), front()),
        (
            "grazing view (89°)",
            quad(),
            CompoundEye::default(),
            grazing(),
        ),
        (
            "lens index 1",
            quad(),
            CompoundEye {
                lens_index: 1.0,
                ..default()
            },
            front(),
        ),
        (
            "R_t = 0.01 (one facet over many meshes)",
            quad(),
            CompoundEye {
                facets_per_uv: 0.01,
                ..default()
            },
            front(),
        ),
        (
            "R_t = 1e4 (facets far below a pixel)",
            quad(),
            CompoundEye {
                facets_per_uv: 1e4,
                ..default()
            },
            front(),
        ),
        (
            "R_t = 1e4 without prefilter",
            quad(),
            CompoundEye {
                facets_per_uv: 1e4,
                prefilter: false,
                ..default()
            },
            grazing(),
        ),
        (
            "radius 1e-6 of the cell",
            quad(),
            CompoundEye {
                lens_radius: 1e-6,
                ..default()
            },
            front(),
        ),
        (
            "R_t = 1e9 (f32 loses the facet's fraction)",
            quad(),
            CompoundEye {
                facets_per_uv: 1e9,
                ..default()
            },
            grazing(),
        ),
        (
            "mirrored UVs",
            quad_with_uvs(|[u, v]| [-u, v]),
            CompoundEye::default(),
            front(),
        ),
        (
            "stretched UVs (u × 4)",
            quad_with_uvs(|[u, v]| [4.0 * u, v]),
            CompoundEye::default(),
            front(),
        ),
    ];
    for (name, mesh, eye, camera) in cases {
        for output in [EyeOutput::Shaded, EyeOutput::PigmentOnly] {
            let frame = render(
                mesh.clone(),
                Some(CompoundEye {
                    output,
                    ..eye.clone()
                }),
                camera,
            );
            assert!(finite(&frame), "{name} ({output:?}): a non-finite pixel");
        }
    }
}

#[test]
fn degenerate_uvs_and_invalid_numbers_fall_back_to_the_base_material() {
    let quad = || quad_with_uvs(|t| t);
    let plain = render(quad(), None, front());
    // All UVs equal: no texture axes, no lattice.
    let flat_uv = render(
        quad_with_uvs(|_| [0.3, 0.7]),
        Some(CompoundEye::default()),
        front(),
    );
    // NaN, zero and out-of-range settings: the lattice is switched off.
    for (name, eye) in [
        (
            "NaN index",
            CompoundEye {
                lens_index: f32::NAN,
                ..default()
            },
        ),
        (
            "NaN R_t",
            CompoundEye {
                facets_per_uv: f32::NAN,
                ..default()
            },
        ),
        (
            "radius 0",
            CompoundEye {
                lens_radius: 0.0,
                ..default()
            },
        ),
        (
            "depth below 2r",
            CompoundEye {
                pigment_depth: 1.0,
                ..default()
            },
        ),
        (
            "index 1e20 (overflows f32 in the refraction)",
            CompoundEye {
                lens_index: 1e20,
                ..default()
            },
        ),
        (
            "depth 1e30 radii",
            CompoundEye {
                pigment_depth: 1e30,
                ..default()
            },
        ),
        (
            "NaN darkness",
            CompoundEye {
                pigment: optica_compound_eye::PigmentDisc {
                    darkness: f32::NAN,
                    ..default()
                },
                ..default()
            },
        ),
    ] {
        assert!(eye.validate().is_err(), "{name} passed validation");
        let frame = render(quad(), Some(eye), front());
        assert!(finite(&frame), "{name}: a non-finite pixel");
        assert_eq!(
            frame.to_rgba8(),
            plain.to_rgba8(),
            "{name}: not the plain base material"
        );
    }
    assert_eq!(
        flat_uv.to_rgba8(),
        plain.to_rgba8(),
        "degenerate UVs: not the plain base material"
    );
    // In the optics-only output a switched-off lattice is a factor of exactly 1.
    let off = render(
        quad(),
        pigment(CompoundEye {
            lens_index: f32::NAN,
            ..default()
        }),
        front(),
    );
    let centre = off.hdr().unwrap().get_pixel(SIZE / 2, SIZE / 2).0;
    assert_eq!(centre[0], 1.0, "{centre:?}");
}

/// The lattice is scale-free: the same eye on a quad from 1e-9 to 1e9 times
/// the size (camera zoomed to match) gives the same optics, in f32, without
/// a NaN (the shader works in a frame scaled to one facet).
#[test]
fn tiny_and_huge_meshes_give_the_same_optics() {
    let eye = pigment(CompoundEye {
        facets_per_uv: 6.0,
        prefilter: false,
        ..default()
    });
    let at = |scale: f32| {
        let frame = Headless::new(SIZE, SIZE)
            .hdr(true)
            .render(scene(
                quad_with_uvs(|t| t),
                Transform::from_scale(Vec3::splat(scale)),
                eye.clone(),
                front(),
                ortho(2.4 * scale),
            ))
            .expect("render");
        assert!(finite(&frame), "scale {scale}: a non-finite pixel");
        frame
            .hdr()
            .unwrap()
            .pixels()
            .map(|p| p.0[0])
            .collect::<Vec<f32>>()
    };
    let unit = at(1.0);
    for scale in [1e-9, 1e-6, 1e6, 1e9] {
        let other = at(scale);
        let mean = unit
            .iter()
            .zip(&other)
            .map(|(a, b)| (a - b).abs())
            .sum::<f32>()
            / unit.len() as f32;
        assert!(
            mean < 0.01,
            "scale {scale}: mean |Δc_t| {mean} against scale 1"
        );
    }
}

/// Each compound-eye mesh's `CompoundEyeStatus` says what became of its
/// material: the defaults draw the lattice with the prefilter's table; a
/// refused setting names the quantity (and the mesh shows its base
/// material, as above); the prefilter switched off is said so.
#[test]
fn the_status_says_whether_the_lattice_and_prefilter_are_drawn() {
    use optica_compound_eye::{CompoundEyeMaterial, CompoundEyeStatus, Error};
    use std::sync::{Arc, Mutex};
    let seen = Arc::new(Mutex::new(Vec::<(String, CompoundEyeStatus)>::new()));
    let log = seen.clone();
    Headless::new(32, 32)
        .frames(4)
        .render(move |app: &mut App| {
            scene(quad_with_uvs(|t| t), Transform::IDENTITY, None, front(), ortho(1.2))(app);
            app.add_systems(
                Startup,
                |mut commands: Commands,
                 mut meshes: ResMut<Assets<Mesh>>,
                 mut eyes: ResMut<Assets<CompoundEyeMaterial>>| {
                    let mesh = meshes.add(quad_with_uvs(|t| t));
                    for (name, extension) in [
                        ("defaults", CompoundEye::default()),
                        (
                            "NaN index",
                            CompoundEye {
                                lens_index: f32::NAN,
                                ..default()
                            },
                        ),
                        (
                            "no prefilter",
                            CompoundEye {
                                prefilter: false,
                                ..default()
                            },
                        ),
                    ] {
                        let material = eyes.add(CompoundEyeMaterial {
                            base: super::base(),
                            extension,
                        });
                        commands.spawn((
                            Name::new(name),
                            Mesh3d(mesh.clone()),
                            MeshMaterial3d(material),
                            Transform::from_xyz(0.0, 0.0, -5.0),
                        ));
                    }
                },
            );
            app.add_systems(Last, move |eyes: Query<(&Name, &CompoundEyeStatus)>| {
                *log.lock().expect("log") =
                    eyes.iter().map(|(n, s)| (n.to_string(), *s)).collect();
            });
        })
        .expect("render");
    let seen = seen.lock().expect("log").clone();
    let status = |name: &str| {
        seen.iter()
            .find(|(n, _)| n == name)
            .map(|(_, s)| *s)
            .expect(name)
    };
    assert_eq!(
        status("defaults"),
        CompoundEyeStatus {
            lattice: true,
            prefiltered: true,
            error: None
        }
    );
    let refused = status("NaN index");
    assert!(!refused.lattice && !refused.prefiltered, "{refused:?}");
    assert!(
        matches!(refused.error, Some(Error::Setting(e)) if e.what == "lens refractive index" && e.value.is_nan()),
        "{refused:?}"
    );
    assert_eq!(
        status("no prefilter"),
        CompoundEyeStatus {
            lattice: true,
            prefiltered: false,
            error: None
        }
    );
}
