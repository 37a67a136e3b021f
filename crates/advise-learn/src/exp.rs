//! The kernel's exponential: `exp(x)` in plain `f64` additions and multiplications, the same bits
//! on every machine, written so that a loop over a buffer of exponents compiles to vector code.
//!
//! LWR's kernel weight is `exp(-d^2 / (2 h^2))`, once per neighbour: at a wide kernel, thousands
//! per query. glibc's `exp` was half of a query's time, one call at a time, and its last bits are
//! glibc's (another libm, another machine, other bits). This one is a function of IEEE double
//! arithmetic alone: no table, no fused multiply-add (Rust never contracts `a * b + c`), no
//! library call, so scalar, SSE2 and AVX2 code give the same bits everywhere. **Bit-identity
//! across machines replaces bit-identity with glibc**: an LWR answer's last bits differ from what
//! `f64::exp` gave, and are the same on every machine.
//!
//! Accuracy (tested against `f64::exp`): within 2 ulp (relative error below `5e-16`) for `x` in
//! `[-708, 709]`, the kernel's range `[ln(tolerance), 0]` included. Below -708 the answer is 0 (a
//! kernel weight under `1e-307`; `f64::exp` would give a subnormal), above 709 +inf, NaN stays
//! NaN. This module owns that function and nothing else; it must stay pure arithmetic.

/// `log2(e)`.
const LOG2E: f64 = std::f64::consts::LOG2_E;
/// `ln 2` split Cody-Waite style (fdlibm's): `LN2_HI` has its low 32 bits zero, so `n * LN2_HI`
/// is exact for the `|n| < 2^11` met here.
const LN2_HI: f64 = 6.931_471_803_691_238e-1;
const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
/// `1.5 * 2^52`: added to `t` (`|t| < 2^51`), it rounds `t` to the nearest integer (ties to even)
/// and leaves that integer in the low bits of the sum.
const SHIFT: f64 = 6_755_399_441_055_744.0;
/// Below this the answer is 0; above [`MAX_X`] +inf (`2^n` stays a normal number between).
const MIN_X: f64 = -708.0;
const MAX_X: f64 = 709.0;

/// `1/k!` for `k = 2..=13`: the Taylor series of `exp(r) - 1 - r` over `r^2`, enough for
/// `|r| <= ln(2)/2` (the remainder `r^14/14!` is below `2^-57`).
const C: [f64; 12] = [
    1.0 / 2.0,
    1.0 / 6.0,
    1.0 / 24.0,
    1.0 / 120.0,
    1.0 / 720.0,
    1.0 / 5_040.0,
    1.0 / 40_320.0,
    1.0 / 362_880.0,
    1.0 / 3_628_800.0,
    1.0 / 39_916_800.0,
    1.0 / 479_001_600.0,
    1.0 / 6_227_020_800.0,
];

/// `e^x`, the same bits on every machine (see the module's documentation for its accuracy).
/// Branch-free (comparisons become selects), so a loop over a slice of it vectorizes.
#[inline(always)]
pub fn exp(x: f64) -> f64 {
    // Keep the arithmetic in range; the ends are patched in at the end.
    let xc = if x < MIN_X { MIN_X } else { x };
    let xc = if xc > MAX_X { MAX_X } else { xc };
    // A NaN fails both comparisons above and flows through as NaN; the integer part below is
    // then garbage, and the final select returns the NaN itself.
    let y = exp_core(xc);
    let y = if x < MIN_X { 0.0 } else { y };
    let y = if x > MAX_X { f64::INFINITY } else { y };
    if x.is_nan() { x } else { y }
}

/// The lowest `x` of [`exp_in_range`]'s range.
pub const IN_RANGE_MIN: f64 = MIN_X;

/// [`exp`] for `x` in `[IN_RANGE_MIN, 0]`: its arithmetic without the clamps and selects that
/// handle the ends and NaN (there they change nothing), so the same bits as [`exp`] on that
/// range, in fewer instructions. Outside it the answer is meaningless (but only a number: no
/// undefined behaviour). A kernel sum whose exponents are known to be in range calls it.
#[inline(always)]
pub fn exp_in_range(x: f64) -> f64 {
    exp_core(x)
}

/// The arithmetic of [`exp`] for `x` in `[MIN_X, MAX_X]`.
#[inline(always)]
fn exp_core(xc: f64) -> f64 {
    let k = xc * LOG2E + SHIFT;
    let n = k - SHIFT;
    let r = (xc - n * LN2_HI) - n * LN2_LO;
    let mut p = C[11];
    for c in C[..11].iter().rev() {
        p = p * r + c;
    }
    let er = 1.0 + (r + r * r * p);
    // `k`'s low bits hold `n + 2^51` (its binade has unit spacing): 2^n built from its bits.
    let n = (k.to_bits() as i64).wrapping_sub(SHIFT.to_bits() as i64);
    let scale = f64::from_bits((n.wrapping_add(1023) as u64) << 52);
    er * scale
}

/// `xs[i] = exp(xs[i])` for every `i`: a loop the compiler vectorizes.
#[inline(always)]
pub fn exp_in_place(xs: &mut [f64]) {
    for x in xs.iter_mut() {
        *x = exp(*x);
    }
}

/// `xs[i] = exp_in_range(xs[i])` for every `i` (each in `[IN_RANGE_MIN, 0]`).
#[inline(always)]
pub fn exp_in_place_in_range(xs: &mut [f64]) {
    for x in xs.iter_mut() {
        *x = exp_in_range(*x);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Units in the last place between `a` and the exact-ish `b` (`f64::exp`, itself within an
    /// ulp), measured at `b`.
    fn ulps(a: f64, b: f64) -> f64 {
        let ulp = f64::from_bits(b.to_bits() + 1) - b;
        ((a - b) / ulp).abs()
    }

    /// Within 2 ulp of `f64::exp` over the kernel's range (a tolerance down to 1e-300) and the
    /// whole normal range, on a dense grid and at random points.
    #[test]
    fn close_to_std_exp() {
        let mut rng = ChaCha8Rng::seed_from_u64(48);
        let mut worst: (f64, f64) = (0.0, 0.0);
        let mut check = |x: f64| {
            let (a, b) = (exp(x), x.exp());
            let u = ulps(a, b);
            assert!(u <= 2.0, "exp({x:e}) = {a:e}, std {b:e}: {u} ulp");
            let rel = ((a - b) / b).abs();
            assert!(rel < 5e-16, "exp({x:e}): relative error {rel:e}");
            if u > worst.1 {
                worst = (x, u);
            }
        };
        // The kernel's range at the default tolerance, [ln(1e-3), 0], densely.
        let lo = (1e-3f64).ln();
        for i in 0..=200_000 {
            check(lo * i as f64 / 200_000.0);
        }
        for _ in 0..200_000 {
            check(rng.random_range(-690.0..0.0));
            check(rng.random_range(-708.0..709.0));
            check(-rng.random_range(0.0..1e-6));
        }
        // Around the reduction's switch points, n ln 2 +- ln 2 / 2.
        for n in -1000..1000 {
            let mid = (f64::from(n) + 0.5) * std::f64::consts::LN_2;
            let mut x = mid;
            for _ in 0..4 {
                if x > MIN_X && x < MAX_X {
                    check(x);
                }
                x = x.next_up();
            }
        }
        assert!(worst.1 <= 2.0, "{worst:?}");
    }

    #[test]
    fn the_ends() {
        assert_eq!(exp(0.0), 1.0);
        assert_eq!(exp(-0.0), 1.0);
        assert_eq!(exp(-708.5), 0.0);
        assert_eq!(exp(f64::NEG_INFINITY), 0.0);
        assert_eq!(exp(710.0), f64::INFINITY);
        assert_eq!(exp(f64::INFINITY), f64::INFINITY);
        assert!(exp(f64::NAN).is_nan());
        assert!(exp(-708.0) > 0.0 && exp(-708.0).is_normal());
    }

    /// The bits themselves, for inputs of the kernel's range and beyond: a change to the
    /// arithmetic (an FMA, a reordered polynomial, another constant) changes some of them, and
    /// with them the last bits of every LWR answer. These are the bits on every machine.
    #[test]
    fn the_same_bits_everywhere() {
        let table: [(f64, u64); 12] = [
            (0.0, 0x3ff0000000000000),
            (-1e-300, 0x3ff0000000000000),
            (-1e-9, 0x3fefffffff768fa1),
            (-0.125, 0x3fec3d6a24ed8222),
            (-0.5, 0x3fe368b2fc6f960a),
            (-1.0, 0x3fd78b56362cef38),
            (-std::f64::consts::LN_2, 0x3fe0000000000000),
            (-std::f64::consts::LN_10, 0x3fb9999999999998),
            (-4.5, 0x3f86c0504695c418),
            (-6.907755278982137, 0x3f50624dd2f1a9fd),
            (-100.0, 0x36ea8c1f14e2af5c),
            (-700.0, 0x00d14f2b0fb9307f),
        ];
        let mut wrong = Vec::new();
        for (x, bits) in table {
            let got = exp(x).to_bits();
            if got != bits {
                wrong.push(format!("({x:?}, {got:#018x})"));
            }
        }
        assert!(wrong.is_empty(), "now: {}", wrong.join(", "));
        // The in-range form gives the same bits on its range: densely over the kernel's range
        // at any tolerance, at its ends, and at random points.
        let mut rng = ChaCha8Rng::seed_from_u64(49);
        let mut xs: Vec<f64> = (0..=100_000)
            .map(|i| IN_RANGE_MIN * f64::from(i) / 100_000.0)
            .collect();
        xs.extend([
            0.0,
            -0.0,
            IN_RANGE_MIN,
            IN_RANGE_MIN.next_up(),
            -1e-300,
            -5e-324,
        ]);
        xs.extend((0..100_000).map(|_| rng.random_range(IN_RANGE_MIN..0.0)));
        xs.extend((0..100_000).map(|_| rng.random_range(-8.0..0.0)));
        for &x in &xs {
            assert_eq!(exp_in_range(x).to_bits(), exp(x).to_bits(), "{x:e}");
        }
        let mut ys = xs.clone();
        exp_in_place_in_range(&mut ys);
        for (x, y) in xs.iter().zip(&ys) {
            assert_eq!(exp(*x).to_bits(), y.to_bits(), "{x}");
        }
        // A slice gives what one call gives (the vectorized loop and the scalar function agree).
        let xs: Vec<f64> = (0..1000).map(|i| -0.00713 * f64::from(i)).collect();
        let mut ys = xs.clone();
        exp_in_place(&mut ys);
        for (x, y) in xs.iter().zip(&ys) {
            assert_eq!(exp(*x).to_bits(), y.to_bits(), "{x}");
        }
    }
}
