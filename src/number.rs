//! How numbers are written back as text: the operator printer, CSV traces and diagnostics all
//! write a value the same way, so what is printed reads back as the same `f64`. No parsing here.

/// Shortest text that reads back as the same `f64` (`-0` is written `0`).
pub fn fmt_num(v: f64) -> String {
    let s = format!("{v}");
    if s == "-0" { "0".into() } else { s }
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
}
