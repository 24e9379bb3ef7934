//! Coating a lens the way lenses are coated: on the glass–air surfaces only.
//!
//! [`crate::lens::LensPrescription::with_coating_everywhere`] also coats
//! cemented glass–glass interfaces, where a low-index layer such as MgF₂
//! (1.38, below both glasses) *raises* the reflectance: the Tessar's
//! cemented surface 1 (n 1.691 | 1.5486) reflects ((n1−n2)/(n1+n2))² =
//! 0.19 % bare and ((n1 n2 − n_c²)/(n1 n2 + n_c²))² = 2.5 % with a
//! quarter-wave of MgF₂ at normal incidence. Real cemented doublets are
//! glued, not coated.

use crate::fresnel::Coating;
use crate::glass::{Glass, LAMBDA_D_NM};
use crate::lens::LensPrescription;

/// The same lens with `coating` on every interface that has air on one side
/// (not on the stop, not on cemented interfaces). "Air" is an index of 1 at
/// the d line.
pub fn coat_air_interfaces(prescription: &LensPrescription, coating: Coating) -> LensPrescription {
    let mut p = prescription.clone();
    // try_index: a glass without an index is not air (`index` would say 1).
    let is_air = |g: &Glass| g.try_index(LAMBDA_D_NM).is_ok_and(|n| (n - 1.0).abs() < 1e-9);
    for k in 0..p.surfaces.len() {
        let Some(before) = p.glass_before(k) else { continue };
        let s = &mut p.surfaces[k];
        if !s.is_stop && (is_air(&before) || is_air(&s.glass_after)) {
            s.coating = Some(coating);
        }
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::builtin;

    #[test]
    fn cemented_surfaces_stay_bare() {
        // US 2,854,889: surface 1 is cemented (n 1.691 | 1.5486), 3 is the
        // stop; 0, 2, 4, 5, 6, 7 touch air.
        let p = coat_air_interfaces(&builtin::tessar(), Coating::quarter_wave(1.38, 550.0));
        let coated: Vec<usize> = (0..8).filter(|&k| p.surfaces[k].coating.is_some()).collect();
        assert_eq!(coated, vec![0, 2, 4, 5, 6, 7]);
    }
}
