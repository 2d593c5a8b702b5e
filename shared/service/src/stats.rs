//! Figures the benchmarks print.

/// The `q` quantile (0 to 1) of `values`, nearest rank; NaN when there are
/// none. Sorts `values`.
pub fn quantile(values: &mut [f64], q: f64) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    values.sort_by(f64::total_cmp);
    values[((values.len() - 1) as f64 * q).round() as usize]
}

#[cfg(test)]
mod tests {
    #[test]
    fn quantiles_by_nearest_rank() {
        let mut v: Vec<f64> = (1..=101).rev().map(f64::from).collect();
        assert_eq!(super::quantile(&mut v, 0.5), 51.0);
        assert_eq!(super::quantile(&mut v, 0.99), 100.0);
        assert_eq!(super::quantile(&mut v, 1.0), 101.0);
        assert!(super::quantile(&mut [], 0.5).is_nan());
    }
}
