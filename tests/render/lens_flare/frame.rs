//! The camera–lens mapping: a light at a point of the camera's picture,
//! traced through the real lens (primary path, a grid over the entrance
//! pupil), is imaged on the sensor where the mapping puts that same point
//! of the picture — within the lens's distortion and coma (the centroid of
//! the f/1.1 double Gauss's spot, wide open 13° off axis, is 0.0092 NDC
//! off; the Tessar's 0.0004): bound 0.02 NDC. A flipped or mis-scaled
//! mapping is off by tenths.

use bevy::math::{DVec2, Vec3};
use optica_lens_flare::twins::{SensorMapping, light_in_lens};
use optica_optics::glass::LAMBDA_D_NM;
use optica_optics::lens::{PreparedLens, TracePath, builtin};
use optica_optics::lens_flare::{Beam, GridOptions, trace_grid};

#[test]
fn a_light_is_imaged_where_the_camera_draws_it() {
    let (fov_y, aspect) = (30f64.to_radians(), 1.5);
    for lens in [builtin::tessar(), builtin::double_gauss()] {
        let efl = lens.paraxial(LAMBDA_D_NM).expect("paraxial").efl_mm;
        let map = SensorMapping::new(efl, fov_y, aspect).expect("mapping");
        for ndc in [
            DVec2::new(0.0, 0.0),
            DVec2::new(0.3, -0.2),
            DVec2::new(-0.6, 0.5),
        ] {
            // The view-space direction to the light drawn at `ndc`, and the
            // direction its light travels.
            let t = (0.5 * fov_y).tan();
            let to_light = Vec3::new((ndc.x * t * aspect) as f32, (ndc.y * t) as f32, -1.0);
            let d = light_in_lens(-to_light).expect("in front");
            let prepared = PreparedLens::new(&lens, LAMBDA_D_NM).expect("prepared");
            let beam = Beam::for_path(&lens, TracePath::Primary, d, LAMBDA_D_NM).expect("beam");
            let grid = trace_grid(
                &prepared,
                TracePath::Primary,
                &beam,
                17,
                &GridOptions::default(),
            )
            .expect("grid");
            let image = grid.centroid().expect("light passes");
            let got = map.ndc(image);
            eprintln!("{}: light at {ndc}, imaged at {got}", lens.name());
            assert!(
                (got - ndc).length() < 0.02,
                "{}: {ndc} → {got}",
                lens.name()
            );
        }
    }
    // Light from behind or beside the camera does not enter the lens.
    assert!(light_in_lens(Vec3::new(0.0, 0.0, -1.0)).is_none());
    assert!(light_in_lens(Vec3::X).is_none());
    assert!(light_in_lens(Vec3::ZERO).is_none());
    assert!(SensorMapping::new(100.0, 0.0, 1.0).is_none());
    assert!(SensorMapping::new(f64::NAN, 0.5, 1.0).is_none());
}
