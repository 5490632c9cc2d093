//! Numeric arguments, checked where clap parses them: finite, with their sign and range, and
//! counts bounded before they size an allocation or a loop. The bound is in the message.

use skin_core::image::{ImageSize, ImageSizeError};

/// A real number in `[lo, hi]` (finite, so NaN and infinities are refused).
pub fn within(lo: f64, hi: f64) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync + 'static {
    move |s| {
        let x = real(s)?;
        if x < lo || x > hi {
            return Err(format!("must be from {lo} to {hi}"));
        }
        Ok(x)
    }
}

/// A real number above `lo` and at most `hi`.
pub fn above(lo: f64, hi: f64) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync + 'static {
    move |s| {
        let x = real(s)?;
        if x <= lo || x > hi {
            return Err(format!("must be above {lo} and at most {hi}"));
        }
        Ok(x)
    }
}

/// A whole number in `[MIN, MAX]`.
pub fn count<const MIN: u64, const MAX: u64>(s: &str) -> Result<usize, String> {
    let n: u64 = s
        .trim()
        .parse()
        .map_err(|_| format!("must be a whole number from {MIN} to {MAX}"))?;
    if !(MIN..=MAX).contains(&n) {
        return Err(format!("must be from {MIN} to {MAX}"));
    }
    usize::try_from(n).map_err(|_| format!("must be at most {}", usize::MAX))
}

/// The number of worker threads: 1 to 256 (more only costs memory and start-up time).
#[cfg(feature = "onnx")] // only the commands that run models use it
pub fn threads(s: &str) -> Result<usize, String> {
    count::<1, 256>(s)
}

fn real(s: &str) -> Result<f64, String> {
    let x: f64 = s.trim().parse().map_err(|_| "must be a number".to_owned())?;
    if !x.is_finite() {
        return Err("must be a finite number".to_owned());
    }
    Ok(x)
}

/// Image sizes: `ROWSxCOLS`, each side 1 to [`ImageSize::MAX_SIDE`] pixels (an 8-bit image of
/// 16 MB at most), read by the one parser the libraries use.
pub fn image_size(s: &str) -> Result<ImageSize, String> {
    s.parse().map_err(|e: ImageSizeError| e.to_string())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn non_finite_and_out_of_range_numbers_are_refused_with_the_range() {
        let f = within(0.0, 1.0);
        assert_eq!(f("0.5"), Ok(0.5));
        assert!(f("NaN").unwrap_err().contains("finite"));
        assert!(f("inf").is_err());
        assert!(f("-0.5").unwrap_err().contains("from 0 to 1"));
        assert!(f("2").is_err());
        assert!(above(0.0, 10.0)("0").is_err());
        assert_eq!(count::<1, 10>("10"), Ok(10));
        assert!(count::<1, 10>("0").unwrap_err().contains("from 1 to 10"));
        assert!(count::<1, 10>("4294967295").is_err());
        assert!(threads("100000").is_err());
        assert_eq!(image_size("68x100"), Ok(ImageSize { rows: 68, cols: 100 }));
        assert!(image_size("100000x100000").unwrap_err().contains("4096"));
        assert!(image_size("0x5").is_err());
    }
}
