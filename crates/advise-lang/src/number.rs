//! How numbers are written as text: [`fmt_num`] for what must read back as the same `f64` (the
//! operator printer, CSV traces), [`fmt_readable`] for messages. No parsing here.

/// Shortest text that reads back as the same `f64` (`-0` is written `0`).
pub fn fmt_num(v: f64) -> String {
    let s = format!("{v}");
    if s == "-0" { "0".into() } else { s }
}

/// A number as a person would write it in a message: `1e300`, not three hundred digits (very
/// large and very small magnitudes in exponent form).
pub fn fmt_readable(v: f64) -> String {
    let a = v.abs();
    if v.is_finite() && v != 0.0 && !(1e-4..1e6).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_back_and_negative_zero_is_zero() {
        for v in [0.1, -2.5, 1e300, 5e-324, 3.0] {
            assert_eq!(fmt_num(v).parse::<f64>().unwrap(), v);
        }
        assert_eq!(fmt_num(-0.0), "0");
        assert_eq!(fmt_num(3.0), "3");
    }

    #[test]
    fn readable_numbers_use_exponents_only_far_from_one() {
        assert_eq!(fmt_readable(1e300), "1e300");
        assert_eq!(fmt_readable(-2e-9), "-2e-9");
        assert_eq!(fmt_readable(0.25), "0.25");
        assert_eq!(fmt_readable(f64::NAN), "NaN");
        assert_eq!(fmt_readable(0.0), "0");
    }
}
