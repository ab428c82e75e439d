//! Image comparison as the evaluation protocol defines it (Naik, thesis Eq. 6.2):
//! PSNR of 8-bit colour (the mean of the R, G and B squared errors) over the
//! valid mask, the pixels covered in both images (disocclusions excluded), and
//! the RMSE of inverse depth over the same mask.

use serde::Serialize;

/// What a comparison reports.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Comparison {
    /// PSNR in dB over the valid mask (`inf` for identical images).
    pub psnr: f64,
    /// Fraction of pixels in the valid mask.
    pub valid_fraction: f64,
    /// RMSE of `1/z` over the valid mask, when both depths are given.
    pub inverse_depth_rmse: Option<f64>,
}

/// Compares two RGB images of the same size. The valid mask is where both
/// depths are positive when depths are given, else where neither pixel is
/// pure black (the blend's "nothing here").
pub fn compare(a: &[u8], b: &[u8], depths: Option<(&[f32], &[f32])>) -> anyhow::Result<Comparison> {
    anyhow::ensure!(
        a.len() == b.len() && a.len() % 3 == 0,
        "images differ in size ({} and {} bytes)",
        a.len(),
        b.len()
    );
    let n = a.len() / 3;
    if let Some((da, db)) = depths {
        anyhow::ensure!(
            da.len() == n && db.len() == n,
            "depth maps do not match the images' size"
        );
    }
    let valid = |i: usize| match depths {
        Some((da, db)) => da[i] > 0.0 && db[i] > 0.0,
        None => a[3 * i..3 * i + 3] != [0, 0, 0] && b[3 * i..3 * i + 3] != [0, 0, 0],
    };
    let (mut se, mut count, mut inv) = (0f64, 0usize, 0f64);
    for i in (0..n).filter(|&i| valid(i)) {
        count += 1;
        for k in 0..3 {
            let d = f64::from(a[3 * i + k]) - f64::from(b[3 * i + k]);
            se += d * d / 3.0;
        }
        if let Some((da, db)) = depths {
            let d = 1.0 / f64::from(da[i]) - 1.0 / f64::from(db[i]);
            inv += d * d;
        }
    }
    anyhow::ensure!(count > 0, "the images share no valid pixel");
    let mse = se / count as f64;
    Ok(Comparison {
        psnr: if mse > 0.0 {
            10.0 * (255.0 * 255.0 / mse).log10()
        } else {
            f64::INFINITY
        },
        valid_fraction: count as f64 / n as f64,
        inverse_depth_rmse: depths.map(|_| (inv / count as f64).sqrt()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn psnr_of_a_known_error() {
        let a = vec![100u8; 12];
        let mut b = a.clone();
        b[0] = 110; // one channel of one pixel of four: MSE = 100 / 3 / 4
        let c = compare(&a, &b, None).unwrap();
        let want = 10.0 * (255.0f64 * 255.0 / (100.0 / 12.0)).log10();
        assert!((c.psnr - want).abs() < 1e-9);
        assert_eq!(c.valid_fraction, 1.0);
        assert!(compare(&a, &a, None).unwrap().psnr.is_infinite());
    }

    #[test]
    fn mask_excludes_uncovered_pixels_and_depth_rmse_is_on_inverse_depth() {
        let a = vec![50u8; 6];
        let b = vec![50u8; 6];
        let c = compare(&a, &b, Some((&[2.0, 0.0], &[4.0, 1.0]))).unwrap();
        assert_eq!(c.valid_fraction, 0.5);
        assert!((c.inverse_depth_rmse.unwrap() - 0.25).abs() < 1e-12);
    }
}
