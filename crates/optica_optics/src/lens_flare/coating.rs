//! Coating a lens the way lenses are coated: on the glass–air surfaces only.

use crate::fresnel::Coating;
use crate::glass::{Glass, LAMBDA_D_NM};
use crate::lens::{LensPrescription, PrescriptionError};

/// A medium counts as air when its index at the d line is within this of 1:
/// air itself is exactly 1 and every glass is above 1.4, so any tolerance
/// between round-off and 0.4 would do.
const AIR_INDEX_TOLERANCE: f64 = 1e-9;

/// The same lens with `coating` on every interface that has air on one side
/// (not on the stop, not on cemented interfaces). "Air" is an index of 1 at
/// the d line.
///
/// [`LensPrescription::with_coating_everywhere`] also coats cemented
/// glass–glass interfaces, where a low-index layer such as MgF₂ (1.38, below
/// both glasses) *raises* the reflectance: the Tessar's cemented surface 1
/// (n 1.691 | 1.5486) reflects `((n1−n2)/(n1+n2))²` = 0.19 % bare and
/// `((n1 n2 − n_c²)/(n1 n2 + n_c²))²` = 2.5 % with a quarter-wave of MgF₂ at
/// normal incidence (Hecht, *Optics*, 5th ed., §9.7). Real cemented
/// doublets are glued, not coated.
///
/// A coating with an index outside [`crate::lens::INDEX_RANGE`] or a
/// negative thickness is refused ([`PrescriptionError::Surface`]).
pub fn coat_air_interfaces(
    prescription: &LensPrescription,
    coating: Coating,
) -> Result<LensPrescription, PrescriptionError> {
    // try_index: a glass without an index is not air (`index` would say 1).
    let is_air = |g: &Glass| {
        g.try_index(LAMBDA_D_NM)
            .is_ok_and(|n| (n - 1.0).abs() < AIR_INDEX_TOLERANCE)
    };
    let stop = prescription.stop_index();
    let touches_air: Vec<bool> = (0..prescription.surfaces().len())
        .map(|k| {
            let before = prescription.glass_before(k).unwrap_or(Glass::Air);
            k != stop && (is_air(&before) || is_air(&prescription.surfaces()[k].glass_after))
        })
        .collect();
    prescription.edited(|surfaces| {
        for (s, coat) in surfaces.iter_mut().zip(touches_air) {
            if coat {
                s.coating = Some(coating);
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::builtin;

    #[test]
    fn cemented_surfaces_stay_bare() {
        // US 2,854,889: surface 1 is cemented (n 1.691 | 1.5486), 3 is the
        // stop; 0, 2, 4, 5, 6, 7 touch air.
        let p = coat_air_interfaces(
            &builtin::tessar(),
            Coating::quarter_wave(1.38, 550.0).unwrap(),
        )
        .unwrap();
        let coated: Vec<usize> = (0..8)
            .filter(|&k| p.surfaces()[k].coating.is_some())
            .collect();
        assert_eq!(coated, vec![0, 2, 4, 5, 6, 7]);
        let e =
            coat_air_interfaces(&builtin::tessar(), Coating::new(0.5, 100.0).unwrap()).unwrap_err();
        assert!(
            matches!(e, PrescriptionError::Surface { surface: 0, ref input } if input.what == "coating index"),
            "{e}"
        );
    }
}
