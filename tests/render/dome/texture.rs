//! Texture inside refined triangles: the vertex mode's checkerboard room
//! (`optica_report`'s textured room, texels sampled nearest) against the
//! CPU twin's ray through each pixel centre. Refinement places the room's
//! edges and the image's rim within the tolerance; inside its triangles every fragment must
//! show the texel its own ray meets, at a coarse tolerance as at the
//! default one (D11 of `optica_optics::dome`).

use bevy::prelude::*;
use optica_dome::DomeCamera;
use optica_harness::Headless;
use optica_optics::dome::cube_face_axis;
use optica_optics::glam::DVec2;
use optica_report::sweeps::dome_textured::room_against_point_reference;

use super::zenith;

const SIZE: u32 = 160;

/// The fraction of the compared pixels away from the room's edges and the
/// rim (more than the tolerance and a pixel from any pixel whose ray meets
/// another face, or from the image circle) whose grey differs from the reference's, and how many there are.
fn wrong_inside_faces(tolerance_px: f32, exact_attributes: bool) -> (f64, usize) {
    let camera = DomeCamera {
        tolerance_px,
        exact_attributes,
        ..default()
    };
    let dome = camera.projection(SIZE).expect("valid camera");
    let (frame, reference, compared) =
        room_against_point_reference(&Headless::new(SIZE, SIZE), SIZE, camera)
            .expect("the textured room renders");
    let world_from_view = zenith().rotation.as_dquat();
    let face: Vec<Option<[i8; 3]>> = (0..SIZE * SIZE)
        .map(|k| {
            let pixel = DVec2::new(f64::from(k % SIZE) + 0.5, f64::from(k / SIZE) + 0.5);
            dome.unproject(pixel)
                .map(|d| cube_face_axis(world_from_view * d).as_i8vec3().to_array())
        })
        .collect();
    let reach = tolerance_px.ceil() as i32 + 1;
    // Refinement places the rim too: leave out its band as well.
    let inner_rim = dome.rim_radius_px() - f64::from(reach);
    let away_from_edges = |x: i32, y: i32| {
        let centre = DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5);
        if (centre - dome.centre_px()).length() > inner_rim {
            return false;
        }
        let here = face[(y * SIZE as i32 + x) as usize];
        (-reach..=reach).all(|dy| {
            (-reach..=reach).all(|dx| {
                let (u, v) = (x + dx, y + dy);
                u < 0
                    || v < 0
                    || u >= SIZE as i32
                    || v >= SIZE as i32
                    || face[(v * SIZE as i32 + u) as usize].is_none_or(|f| Some(f) == here)
            })
        })
    };
    let (mut wrong, mut n) = (0usize, 0usize);
    for y in 0..SIZE as i32 {
        for x in 0..SIZE as i32 {
            let k = (y * SIZE as i32 + x) as usize;
            if !compared[k] || !away_from_edges(x, y) {
                continue;
            }
            n += 1;
            let (a, b) = (
                frame.get_pixel(x as u32, y as u32)[0],
                reference.get_pixel(x as u32, y as u32)[0],
            );
            if a.abs_diff(b) > 8 {
                wrong += 1;
            }
        }
    }
    (wrong as f64 / n.max(1) as f64, n)
}

/// Every pixel inside a face shows the checker cell its ray meets, however
/// large the refined triangles: at 8 px the room's faces are two triangles
/// across tens of pixels, where interpolated texture coordinates would put
/// cells pixels away from their place (as they do with
/// `exact_attributes` off).
#[test]
fn texture_inside_refined_triangles_is_where_the_lens_puts_it() {
    let (interpolated, _) = wrong_inside_faces(8.0, false);
    assert!(
        interpolated > 0.2,
        "interpolated attributes: only {:.2} % wrong at 8 px",
        100.0 * interpolated
    );
    for tolerance in [8.0, 0.5] {
        let (wrong, n) = wrong_inside_faces(tolerance, true);
        assert!(n > 6000, "{n} pixels compared at {tolerance} px");
        assert!(
            wrong < 0.002,
            "{:.2} % of {n} pixels inside faces show another cell at {tolerance} px",
            100.0 * wrong
        );
    }
}
