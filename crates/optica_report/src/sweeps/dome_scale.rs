//! Dome: what the vertex mode's refinement costs per frame as the scene
//! grows, with the camera moving (every twin refined again each frame).
//!
//! * Scene: a "city" of UV spheres (32 × 16 segments, 960 triangles each)
//!   of 1–10 m radius, 5–300 m around a viewer 1.7 m above the ground,
//!   seeded; 1k to 1M triangles (1 to 1,042 meshes).
//! * Camera: 4096² domemaster, 180°, zenith, 0.5 px; each frame it steps
//!   0.1 m, so every mesh's placement relative to it changes.
//! * time_ms: the plugin's own work for one frame
//!   (`optica_dome::twins::twins_of_meshes` over every mesh, as `refine_twins`
//!   runs it: all the meshes' triangles share the compute pool), on the
//!   machine's threads; baseline: reading every mesh's positions into view
//!   space (what any per-frame CPU pass pays).
//! * Work: input triangles, twin vertices built, meshes left unsplit
//!   (every triangle its own refinement: the twin draws the mesh itself,
//!   nothing is built or uploaded).

use bevy::math::{Affine3A, Quat, Vec3};
use bevy::mesh::{Mesh, VertexAttributeValues};
use bevy::prelude::{Meshable, Sphere};
use optica_dome::DomeCamera;
use optica_dome::twins::{Twin, TwinJob, twins_of_meshes};
use optica_optics::dome::SplitRule;

use crate::{Report, Row, SweepContext, time_paired_ms};

/// Triangles of one sphere of the city.
const SPHERE_TRIANGLES: usize = 960;

/// A small seeded generator (SplitMix64): the city is the same every run.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// The city: one sphere mesh and the world placement of each copy.
fn city(triangles: usize) -> (Mesh, Vec<Affine3A>) {
    let mesh = Sphere::new(1.0).mesh().uv(32, 16);
    let mut rng = Rng(0x00D0_3E5C);
    let count = triangles.div_ceil(SPHERE_TRIANGLES).max(1);
    let places = (0..count)
        .map(|_| {
            let distance = 5.0 + 295.0 * rng.next();
            let azimuth = std::f32::consts::TAU * rng.next();
            let radius = 1.0 + 9.0 * rng.next();
            let height = radius * (rng.next() - 0.3);
            Affine3A::from_scale_rotation_translation(
                Vec3::splat(radius),
                Quat::IDENTITY,
                Vec3::new(distance * azimuth.cos(), height, distance * azimuth.sin()),
            )
        })
        .collect();
    (mesh, places)
}

/// The dome camera's view-from-world at step `k` of its walk.
fn camera_at(k: usize) -> Affine3A {
    let eye = Vec3::new(0.1 * k as f32, 1.7, 0.0);
    Affine3A::look_to_rh(eye, Vec3::Y, Vec3::Z)
}

/// Adds the series `scene size, moving camera` to `report`.
pub fn scene_size(report: &mut Report, ctx: &SweepContext) {
    let sizes: Vec<usize> = ctx.pick(vec![1_000, 10_000], vec![1_000, 10_000, 100_000, 1_000_000]);
    let camera = DomeCamera::default();
    let projection = camera.projection(4096).expect("a valid dome");
    let rule = SplitRule::chord_gap(f64::from(camera.tolerance_px)).expect("a valid tolerance");
    let (runs, budget) = ctx.pick((2, 200.0), (3, 2_000.0));
    for (i, &size) in sizes.iter().enumerate() {
        ctx.progress(i + 1, sizes.len(), &format!("scene of {size} triangles"));
        let (mesh, places) = city(size);
        let mut step = 0;
        // The baseline, timed against the refinement in alternating blocks.
        let transform_only = || {
            let Some(VertexAttributeValues::Float32x3(p)) =
                mesh.attribute(Mesh::ATTRIBUTE_POSITION)
            else {
                return 0.0;
            };
            let view = camera_at(0);
            places
                .iter()
                .map(|place| {
                    let m = view * *place;
                    p.iter()
                        .map(|v| m.transform_point3(Vec3::from_array(*v)).z)
                        .sum::<f32>()
                })
                .sum::<f32>()
        };
        let projection = projection.into();
        let refine = || {
            step += 1;
            let view = camera_at(step);
            let jobs: Vec<TwinJob> = places
                .iter()
                .map(|place| TwinJob {
                    source: &mesh,
                    view_from_local: view * *place,
                    projection: &projection,
                    rule,
                })
                .collect();
            twins_of_meshes(&jobs)
                .into_iter()
                .flatten()
                .fold((0, 0), |(v, u), twin| match twin {
                    Twin::Same => (v, u + 1),
                    Twin::Refined(m) => (v + m.count_vertices(), u),
                })
        };
        let (timed, (vertices, unsplit)) =
            time_paired_ms(ctx.blocks().0, runs, budget, refine, transform_only);
        report.rows.push(
            Row::paired_cpu(size as f64, &timed)
                .series("scene size, moving camera (knob: triangles)")
                .work("input_triangles", (places.len() * SPHERE_TRIANGLES) as f64)
                .work("meshes", places.len() as f64)
                .work("twin_vertices", vertices as f64)
                .work("unsplit_meshes", unsplit as f64),
        );
    }
}
