//! Uncertainty of success rates: binomial confidence intervals.
//!
//! A success rate measured on `n` episodes is an estimate `p = k / n` of a
//! binomial proportion; at `n = 100` one standard error is up to 5 points,
//! more than many differences between methods. Every success rate the project
//! reports carries its 95 % interval.
//!
//! **Wilson score interval** (Wilson 1927). With `z` the normal quantile
//! (1.959964 for 95 %),
//!
//! ```text
//! centre = (p + z^2 / 2n) / (1 + z^2 / n)
//! half   = z / (1 + z^2 / n) * sqrt(p (1 - p) / n + z^2 / 4n^2)
//! [l, u] = [centre - half, centre + half]
//! ```
//!
//! It stays inside `[0, 1]`, is never empty at `k = 0` or `k = n` (unlike the
//! normal approximation `p ± z sqrt(p(1-p)/n)`), and covers close to 95 % at
//! the sizes used here.
//!
//! **Difference of two rates** (Newcombe 1998, method 10, the hybrid score
//! interval). For independent `p1` with interval `[l1, u1]` and `p2` with
//! `[l2, u2]`, `d = p1 - p2` has
//!
//! ```text
//! lower = d - sqrt((p1 - l1)^2 + (u2 - p2)^2)
//! upper = d + sqrt((u1 - p1)^2 + (p2 - l2)^2)
//! ```
//!
//! Two policies evaluated on the same test seeds are paired, not independent;
//! the unpaired interval is then conservative (wider than a paired one).

use serde::{Deserialize, Serialize};

/// The normal quantile of a two-sided 95 % interval.
pub const Z_95: f64 = 1.959_963_984_540_054;

/// A confidence interval `[lower, upper]` around an estimate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    /// The point estimate.
    pub estimate: f64,
    /// The lower bound.
    pub lower: f64,
    /// The upper bound.
    pub upper: f64,
}

impl Interval {
    /// The 95 % Wilson score interval of `successes` out of `trials`; `None`
    /// with no trials or more successes than trials.
    ///
    /// ```
    /// use fmsr_core::interval::Interval;
    /// let i = Interval::wilson(32, 100).unwrap();
    /// assert_eq!(format!("{:.3} [{:.3}, {:.3}]", i.estimate, i.lower, i.upper), "0.320 [0.237, 0.417]");
    /// // Never empty at the edges.
    /// assert!(Interval::wilson(0, 100).unwrap().upper > 0.03);
    /// assert!(Interval::wilson(5, 0).is_none());
    /// ```
    #[must_use]
    pub fn wilson(successes: usize, trials: usize) -> Option<Self> {
        Self::wilson_z(successes, trials, Z_95)
    }

    /// The Wilson score interval at normal quantile `z`.
    #[must_use]
    pub fn wilson_z(successes: usize, trials: usize, z: f64) -> Option<Self> {
        if trials == 0 || successes > trials {
            return None;
        }
        let n = trials as f64;
        let p = successes as f64 / n;
        let z2 = z * z;
        let denom = 1.0 + z2 / n;
        let centre = (p + z2 / (2.0 * n)) / denom;
        let half = z / denom * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt();
        // At 0 and at n successes the bound on that side is exactly 0 or 1;
        // computed, it can miss by a rounding error and exclude the estimate.
        let lower = if successes == 0 { 0.0 } else { (centre - half).max(0.0) };
        let upper = if successes == trials { 1.0 } else { (centre + half).min(1.0) };
        Some(Self { estimate: p, lower, upper })
    }

    /// The 95 % interval of the difference `self - other` of two independent
    /// rates with Wilson intervals (Newcombe's hybrid score interval).
    ///
    /// ```
    /// use fmsr_core::interval::Interval;
    /// let a = Interval::wilson(56, 100).unwrap();
    /// let b = Interval::wilson(35, 100).unwrap();
    /// let d = a.difference(&b);
    /// assert_eq!(format!("{:+.3} [{:+.3}, {:+.3}]", d.estimate, d.lower, d.upper), "+0.210 [+0.072, +0.337]");
    /// ```
    #[must_use]
    pub fn difference(&self, other: &Self) -> Self {
        let d = self.estimate - other.estimate;
        let lower = d - ((self.estimate - self.lower).powi(2) + (other.upper - other.estimate).powi(2)).sqrt();
        let upper = d + ((self.upper - self.estimate).powi(2) + (other.estimate - other.lower).powi(2)).sqrt();
        Self { estimate: d, lower, upper }
    }

    /// Whether `x` lies in `[lower, upper]`.
    #[must_use]
    pub fn contains(&self, x: f64) -> bool {
        self.lower <= x && x <= self.upper
    }

    /// In percent, with whole points: `32% [24, 42]`.
    ///
    /// ```
    /// use fmsr_core::interval::Interval;
    /// assert_eq!(Interval::wilson(32, 100).unwrap().percent(), "32% [24, 42]");
    /// ```
    #[must_use]
    pub fn percent(&self) -> String {
        format!("{:.0}% [{:.0}, {:.0}]", 100.0 * self.estimate, 100.0 * self.lower, 100.0 * self.upper)
    }

    /// A difference in points, signed: `+21 pts [+7, +34]`.
    ///
    /// ```
    /// use fmsr_core::interval::Interval;
    /// let d = Interval::wilson(56, 100).unwrap().difference(&Interval::wilson(35, 100).unwrap());
    /// assert_eq!(d.points(), "+21 pts [+7, +34]");
    /// ```
    #[must_use]
    pub fn points(&self) -> String {
        format!("{:+.0} pts [{:+.0}, {:+.0}]", 100.0 * self.estimate, 100.0 * self.lower, 100.0 * self.upper)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    // Regression: proptest found 10 successes in 10 trials with an upper
    // bound of 0.9999999999999999, an interval that excluded its estimate.
    #[test]
    fn all_or_no_successes_reach_the_ends_exactly() {
        for n in [1, 3, 10, 100, 4999] {
            assert_eq!(Interval::wilson(n, n).unwrap().upper, 1.0, "{n}/{n}");
            assert_eq!(Interval::wilson(0, n).unwrap().lower, 0.0, "0/{n}");
        }
    }

    proptest! {
        /// The interval holds its estimate and stays in [0, 1].
        #[test]
        fn wilson_contains_estimate(n in 1usize..5000, frac in 0.0f64..=1.0) {
            let k = ((n as f64) * frac).round() as usize;
            let i = Interval::wilson(k, n).unwrap();
            prop_assert!(i.contains(i.estimate));
            prop_assert!(0.0 <= i.lower && i.upper <= 1.0 && i.lower < i.upper);
        }

        /// Swapping successes and failures mirrors the interval about 1/2.
        #[test]
        fn wilson_symmetric(n in 1usize..2000, frac in 0.0f64..=1.0) {
            let k = ((n as f64) * frac).round() as usize;
            let a = Interval::wilson(k, n).unwrap();
            let b = Interval::wilson(n - k, n).unwrap();
            prop_assert!((a.lower - (1.0 - b.upper)).abs() < 1e-12);
            prop_assert!((a.upper - (1.0 - b.lower)).abs() < 1e-12);
        }

        /// More trials at the same rate narrow the interval.
        #[test]
        fn wilson_narrows(k in 0usize..200, scale in 2usize..10) {
            let n = 200;
            let a = Interval::wilson(k, n).unwrap();
            let b = Interval::wilson(k * scale, n * scale).unwrap();
            prop_assert!(b.upper - b.lower < a.upper - a.lower);
        }

        /// The difference's interval holds its estimate, and reversing the
        /// pair negates it.
        #[test]
        fn difference_antisymmetric(n1 in 1usize..1000, f1 in 0.0f64..=1.0, n2 in 1usize..1000, f2 in 0.0f64..=1.0) {
            let a = Interval::wilson(((n1 as f64) * f1).round() as usize, n1).unwrap();
            let b = Interval::wilson(((n2 as f64) * f2).round() as usize, n2).unwrap();
            let d = a.difference(&b);
            let e = b.difference(&a);
            prop_assert!(d.contains(d.estimate));
            prop_assert!((d.lower + e.upper).abs() < 1e-12 && (d.upper + e.lower).abs() < 1e-12);
            prop_assert!(-1.0 <= d.lower && d.upper <= 1.0);
        }
    }

    /// The coverage of the Wilson interval at n = 100, p = 0.3, summed exactly
    /// over the binomial distribution, is near its nominal 95 %.
    #[test]
    fn wilson_coverage_near_nominal() {
        let (n, p) = (100usize, 0.3f64);
        let mut coverage = 0.0;
        let mut ln_choose = 0.0f64; // ln C(n, k)
        for k in 0..=n {
            if k > 0 {
                ln_choose += ((n - k + 1) as f64).ln() - (k as f64).ln();
            }
            let pmf = (ln_choose + k as f64 * p.ln() + (n - k) as f64 * (1.0 - p).ln()).exp();
            if Interval::wilson(k, n).unwrap().contains(p) {
                coverage += pmf;
            }
        }
        assert!((0.93..0.97).contains(&coverage), "coverage {coverage}");
    }

    /// Textbook values: 81 of 263 (Newcombe 1998, Table I, example with
    /// Wilson limits 0.2553, 0.3662).
    #[test]
    fn wilson_textbook_value() {
        let i = Interval::wilson(81, 263).unwrap();
        assert!((i.lower - 0.2553).abs() < 5e-4 && (i.upper - 0.3662).abs() < 5e-4, "{i:?}");
    }

    /// Newcombe (1998, difference of independent proportions), 56/70 against
    /// 48/80: method 10 gives 0.0524 to 0.3339.
    #[test]
    fn difference_textbook_value() {
        let d = Interval::wilson(56, 70).unwrap().difference(&Interval::wilson(48, 80).unwrap());
        assert!((d.lower - 0.0524).abs() < 5e-4 && (d.upper - 0.3339).abs() < 5e-4, "{d:?}");
    }
}
