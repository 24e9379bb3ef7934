//! Image error of a foveated render against the full-quality render.

use glam::DVec3;

use super::error::FoveatedError;
use crate::input;

/// RMS difference over all pixels and the three linear-RGB channels.
/// Errors as [`weighted_rmse`].
pub fn rmse(a: &[DVec3], b: &[DVec3]) -> Result<f64, FoveatedError> {
    weighted_rmse(a, b, &vec![1.0; a.len()])
}

/// Weighted RMS difference √(Σ wᵢ |aᵢ − bᵢ|² / (3 Σ wᵢ)), the report's
/// `gaze_weighted_rmse` when the weights are the pixels' continuous eq. 8
/// levels: an error where the viewer looks counts fully, one outside the
/// field not at all. This is the error the method promises to keep small;
/// plain [`rmse`] also counts the periphery it deliberately degrades. All
/// weights zero gives 0 (no pixel the viewer can see).
///
/// Errors: [`FoveatedError::LengthMismatch`] when `b` or `w` differs in
/// length from `a`; [`FoveatedError::Input`] for a negative or non-finite
/// weight or a non-finite pixel.
pub fn weighted_rmse(a: &[DVec3], b: &[DVec3], w: &[f64]) -> Result<f64, FoveatedError> {
    for (what, len) in [
        ("pixels of the second image", b.len()),
        ("pixel weights", w.len()),
    ] {
        if len != a.len() {
            return Err(FoveatedError::LengthMismatch {
                what,
                expected: a.len(),
                got: len,
            });
        }
    }
    for &x in w {
        input::non_negative("pixel weight", x)?;
    }
    for &p in a.iter().chain(b) {
        input::finite_vec3("pixel colour", p)?;
    }
    let sw: f64 = w.iter().sum();
    if sw == 0.0 {
        return Ok(0.0);
    }
    let se: f64 = a
        .iter()
        .zip(b)
        .zip(w)
        .map(|((p, q), &x)| x * (*p - *q).length_squared())
        .sum();
    Ok((se / (3.0 * sw)).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::{Expected, InvalidInput};

    #[test]
    fn hand_computed_errors() {
        // One pixel off by (0.3, 0, 0.4) (|d|² = 0.25) of four: √(0.25/12) = 0.1443.
        let a = vec![DVec3::ZERO; 4];
        let mut b = a.clone();
        b[2] = DVec3::new(0.3, 0.0, 0.4);
        assert!((rmse(&a, &b).unwrap() - (0.25f64 / 12.0).sqrt()).abs() < 1e-15);
        // Weight only that pixel: √(0.25/3).
        let w = [0.0, 0.0, 1.0, 0.0];
        assert!((weighted_rmse(&a, &b, &w).unwrap() - (0.25f64 / 3.0).sqrt()).abs() < 1e-15);
        // Weight only the others: 0.
        assert_eq!(weighted_rmse(&a, &b, &[1.0, 1.0, 0.0, 1.0]).unwrap(), 0.0);
        assert_eq!(weighted_rmse(&a, &b, &[0.0; 4]).unwrap(), 0.0);
    }

    #[test]
    fn bad_inputs_are_typed_errors() {
        let a = vec![DVec3::ZERO; 4];
        let mut b = a.clone();
        let weight = |x: f64| match weighted_rmse(&a, &b, &[x, 0.0, 0.0, 0.0]) {
            Err(FoveatedError::Input(e)) => (e.what, e.expected),
            other => panic!("{other:?}"),
        };
        assert_eq!(weight(f64::NAN), ("pixel weight", Expected::NonNegative));
        assert_eq!(weight(-1.0), ("pixel weight", Expected::NonNegative));
        assert_eq!(
            rmse(&a, &b[1..]),
            Err(FoveatedError::LengthMismatch {
                what: "pixels of the second image",
                expected: 4,
                got: 3
            })
        );
        assert_eq!(
            weighted_rmse(&a, &b, &[1.0]),
            Err(FoveatedError::LengthMismatch {
                what: "pixel weights",
                expected: 4,
                got: 1
            })
        );
        b[0] = DVec3::new(0.0, f64::INFINITY, 0.0);
        assert_eq!(
            rmse(&a, &b),
            Err(FoveatedError::Input(InvalidInput::new(
                "pixel colour",
                f64::INFINITY,
                Expected::FiniteVector
            )))
        );
    }
}
