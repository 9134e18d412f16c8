//! Exact sums of f64 values ([`Exact`]): every value is added without rounding into a
//! fixed-point accumulator that spans the whole f64 range, and the sum is rounded once,
//! to the nearest f64, when it is read. The result does not depend on the order of the
//! additions, so a sum over particles has the same bits whatever the number of threads
//! or ranks that share the particles, and whatever order they are combined in.

use crate::core::parallel::MIN_CHUNK;
use rayon::prelude::*;
use std::iter::Sum;

/// Bits per limb: the digits of the accumulator are base 2³².
const LIMB_BITS: u32 = 32;
/// Bit 0 of limb 0 weighs 2⁻¹⁰⁷⁴, the smallest subnormal f64; the top bit of the largest
/// finite f64 (2¹⁰²³) is bit 2097, in limb 65. Limb 66 takes the carries and the sign.
const LIMBS: usize = 67;
/// Additions between normalisations: each adds less than 2³² to a limb and normalised
/// limbs are below 2³², so a limb stays below 2⁶² in magnitude, inside an i64.
const NORMALISE_EVERY: u32 = 1 << 30;

/// An exact sum of f64 values, rounded to the nearest f64 (ties to even) by
/// [`Exact::value`]. Non-finite values are summed apart, as f64s, and win: a sum with an
/// infinity or a NaN among its terms reads as their f64 sum.
#[derive(Clone, Debug, PartialEq)]
pub struct Exact {
    /// The sum in units of 2⁻¹⁰⁷⁴, as signed base-2³² digits that carry lazily.
    limbs: [i64; LIMBS],
    /// Additions since the last normalisation.
    pending: u32,
    /// The sum of the non-finite terms; 0 if there were none.
    special: f64,
}

impl Default for Exact {
    fn default() -> Self {
        Self {
            limbs: [0; LIMBS],
            pending: 0,
            special: 0.0,
        }
    }
}

impl From<f64> for Exact {
    fn from(x: f64) -> Self {
        let mut e = Self::default();
        e.add(x);
        e
    }
}

impl Sum<f64> for Exact {
    fn sum<I: Iterator<Item = f64>>(iter: I) -> Self {
        let mut e = Self::default();
        iter.for_each(|x| e.add(x));
        e
    }
}

impl Sum<Exact> for Exact {
    fn sum<I: Iterator<Item = Exact>>(iter: I) -> Self {
        let mut e = Self::default();
        iter.for_each(|x| e.merge(&x));
        e
    }
}

impl<'a> Sum<&'a Exact> for Exact {
    fn sum<I: Iterator<Item = &'a Exact>>(iter: I) -> Self {
        let mut e = Self::default();
        iter.for_each(|x| e.merge(x));
        e
    }
}

impl Exact {
    /// The number of words of [`Self::words`].
    pub const WORDS: usize = LIMBS + 1;

    /// Adds x exactly.
    pub fn add(&mut self, x: f64) {
        if !x.is_finite() {
            self.special += x;
            return;
        }
        if x == 0.0 {
            return;
        }
        // x = ±m 2^(p − 1074) with m the 53-bit significand (52 bits for a subnormal).
        let bits = x.to_bits();
        let exponent = ((bits >> 52) & 0x7ff) as u32;
        let fraction = bits & ((1 << 52) - 1);
        let (m, p) = match exponent {
            0 => (fraction, 0),
            e => (fraction | 1 << 52, e - 1),
        };
        let (limb, shift) = ((p / LIMB_BITS) as usize, p % LIMB_BITS);
        let wide = u128::from(m) << shift;
        let sign = if x < 0.0 { -1 } else { 1 };
        for k in 0..3 {
            let digit = (wide >> (LIMB_BITS * k as u32)) as u32;
            self.limbs[limb + k] += sign * i64::from(digit);
        }
        self.pending += 1;
        if self.pending == NORMALISE_EVERY {
            self.normalise();
        }
    }

    /// Adds another exact sum.
    pub fn merge(&mut self, other: &Exact) {
        let mut other = other.clone();
        other.normalise();
        self.normalise();
        for (a, b) in self.limbs.iter_mut().zip(&other.limbs) {
            *a += b;
        }
        // Each limb is now below 2³³: two additions' worth.
        self.pending = 2;
        self.special += other.special;
    }

    /// The two sums added.
    pub fn merged(mut self, other: Exact) -> Exact {
        self.merge(&other);
        self
    }

    /// Carries every limb into the next, leaving digits in [0, 2³²) below the top limb,
    /// which keeps the sign.
    fn normalise(&mut self) {
        for k in 0..LIMBS - 1 {
            let carry = self.limbs[k] >> LIMB_BITS;
            self.limbs[k] -= carry << LIMB_BITS;
            self.limbs[k + 1] += carry;
        }
        self.pending = 0;
    }

    /// The sum, rounded to the nearest f64, ties to even (a sum in the subnormal range is
    /// rounded twice, to 53 bits and then to the subnormal's).
    pub fn value(&self) -> f64 {
        // Non-zero for an infinity or a NaN (NaN != 0).
        if self.special != 0.0 {
            return self.special;
        }
        let mut n = self.clone();
        n.normalise();
        let negative = n.limbs[LIMBS - 1] < 0;
        if negative {
            n.limbs.iter_mut().for_each(|l| *l = -*l);
            n.normalise();
        }
        let sign = if negative { -1.0 } else { 1.0 };
        let Some(top) = n.limbs.iter().rposition(|&l| l != 0) else {
            return 0.0;
        };
        if top == LIMBS - 1 {
            return sign * f64::INFINITY;
        }
        // The top three digits (at least 65 significant bits), with a sticky bit for any
        // lower one, round to the nearest f64 as the whole sum does.
        let low = top.saturating_sub(2);
        let mut wide = (low..=top)
            .rev()
            .fold(0u128, |w, k| w << LIMB_BITS | u128::from(n.limbs[k] as u32));
        if n.limbs[..low].iter().any(|&l| l != 0) {
            wide |= 1;
        }
        // Scaled by 2^e in two exact halves, so that neither factor leaves the normal range.
        let e = (LIMB_BITS as usize * low) as i32 - 1074;
        let half = e / 2;
        sign * (wide as f64) * power_of_two(half) * power_of_two(e - half)
    }

    /// The sum as words exact in f64 (normalised digits, and the non-finite terms' sum),
    /// to send to another rank.
    pub fn words(&self) -> Vec<f64> {
        let mut n = self.clone();
        n.normalise();
        let mut out: Vec<f64> = n.limbs.iter().map(|&l| l as f64).collect();
        out.push(n.special);
        out
    }

    /// The sum of [`Self::words`].
    pub fn from_words(words: &[f64]) -> Exact {
        assert_eq!(words.len(), Self::WORDS, "an exact sum's words");
        let mut e = Exact::default();
        for (l, &w) in e.limbs.iter_mut().zip(words) {
            *l = w as i64;
        }
        e.special = words[LIMBS];
        e
    }
}

/// The exact sum of map(0), …, map(n − 1), in parallel.
pub fn par_sum(n: usize, map: impl Fn(usize) -> f64 + Sync) -> Exact {
    (0..n)
        .into_par_iter()
        .with_min_len(MIN_CHUNK)
        .fold(Exact::default, |mut e, i| {
            e.add(map(i));
            e
        })
        .reduce(Exact::default, Exact::merged)
}

/// The exact sums of the K components of map(0), …, map(n − 1), in parallel.
pub fn par_sums<const K: usize>(n: usize, map: impl Fn(usize) -> [f64; K] + Sync) -> [Exact; K] {
    let merged = |mut a: [Exact; K], b: [Exact; K]| {
        a.iter_mut().zip(&b).for_each(|(a, b)| a.merge(b));
        a
    };
    (0..n)
        .into_par_iter()
        .with_min_len(MIN_CHUNK)
        .fold(
            || std::array::from_fn(|_| Exact::default()),
            |mut e: [Exact; K], i| {
                e.iter_mut().zip(map(i)).for_each(|(e, x)| e.add(x));
                e
            },
        )
        .reduce(|| std::array::from_fn(|_| Exact::default()), merged)
}

/// The ranks that share a system's particles, as a rate evaluation sees them: each rank
/// sums its own particles' shares ([`crate::reference::Reference::counted`]) and
/// [`Ranks::add_others`] adds the other ranks' shares, so that every rank holds the sums
/// over all particles, with the bits of one rank's; [`Ranks::max`], [`Ranks::worst`] and
/// [`Ranks::refresh`] serve an iteration inside a rate evaluation (the mixed family's
/// pseudo time) and the agreement on a blow-up before its collectives. Every rank calls
/// each at the same point of the run.
pub trait Ranks: Send + Sync {
    /// Adds the other ranks' shares to `sums`.
    fn add_others(&self, sums: &mut [Exact]);
    /// Each of `values` the largest of the ranks'.
    fn max(&self, values: &mut [f64]);
    /// The largest of the ranks' `size`, each at its local particle `particle` (the
    /// lowest global id on ties, as one rank's scan in particle order finds it): whether
    /// it is this rank's, and the size.
    fn worst(&self, particle: usize, size: f64) -> (bool, f64);
    /// Overwrites the rows of the rank's ghosts with their owners': `put(ids, out)`
    /// appends the rows of the local particles `ids`, `take(ids, words)` overwrites
    /// them.
    fn refresh(&self, put: &dyn Fn(&[u32], &mut Vec<f64>), take: &mut dyn FnMut(&[u32], &[f64]));
}

/// A run on one rank: its sums are complete, and it has no ghosts.
pub struct OneRank;

impl Ranks for OneRank {
    fn add_others(&self, _sums: &mut [Exact]) {}

    fn max(&self, _values: &mut [f64]) {}

    fn worst(&self, _particle: usize, size: f64) -> (bool, f64) {
        (true, size)
    }

    fn refresh(&self, _put: &dyn Fn(&[u32], &mut Vec<f64>), _take: &mut dyn FnMut(&[u32], &[f64])) {
    }
}

/// 2^e for −1022 ≤ e ≤ 1023.
fn power_of_two(e: i32) -> f64 {
    debug_assert!((-1022..=1023).contains(&e));
    f64::from_bits(((e + 1023) as u64) << 52)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic stream of values over many magnitudes and both signs.
    fn values(n: usize, seed: u64) -> Vec<f64> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let mantissa = (s >> 11) as f64 / (1u64 << 53) as f64;
                let exponent = ((s >> 3) % 80) as i32 - 40;
                let sign = if s & 1 == 0 { 1.0 } else { -1.0 };
                sign * mantissa * 2f64.powi(exponent)
            })
            .collect()
    }

    #[test]
    fn sums_that_f64_holds_exactly_are_exact() {
        // Integers below 2⁵³ and dyadic fractions add without rounding in f64.
        let xs = [1.0, 2.0, 0.5, -0.25, 1e15, -3.0, 2f64.powi(-40)];
        assert_eq!(
            xs.iter().copied().sum::<Exact>().value(),
            xs.iter().sum::<f64>()
        );
        assert_eq!(Exact::default().value(), 0.0);
        assert_eq!(Exact::from(-7.5).value(), -7.5);
        for x in [
            f64::MAX,
            f64::MIN_POSITIVE,
            5e-324,
            -5e-324,
            -f64::MAX,
            1.0 / 3.0,
        ] {
            assert_eq!(Exact::from(x).value(), x, "{x:e}");
        }
    }

    #[test]
    fn cancellation_leaves_the_exact_remainder() {
        // f64 loses the 1 entirely: (1e17 + 1) − 1e17 = 0 in f64, 1 exactly here.
        let e: Exact = [1e17, 1.0, -1e17].into_iter().sum();
        assert_eq!(e.value(), 1.0);
        let tiny = 2f64.powi(-1000);
        let e: Exact = [1e300, tiny, -1e300].into_iter().sum();
        assert_eq!(e.value(), tiny);
    }

    #[test]
    fn rounds_to_nearest_with_ties_to_even() {
        let ulp = 2f64.powi(-52);
        // 1 + ulp/2 is a tie: to even, 1. Slightly more rounds up.
        let tie: Exact = [1.0, ulp / 2.0].into_iter().sum();
        assert_eq!(tie.value(), 1.0);
        let above: Exact = [1.0, ulp / 2.0, 2f64.powi(-200)].into_iter().sum();
        assert_eq!(above.value(), 1.0 + ulp);
        let odd_tie: Exact = [1.0 + ulp, ulp / 2.0].into_iter().sum();
        assert_eq!(odd_tie.value(), 1.0 + 2.0 * ulp);
        let negative: Exact = [-1.0, -ulp / 2.0, -2f64.powi(-200)].into_iter().sum();
        assert_eq!(negative.value(), -1.0 - ulp);
    }

    #[test]
    fn the_sum_does_not_depend_on_order_or_grouping() {
        let xs = values(10_000, 7);
        let forward: Exact = xs.iter().copied().sum();
        let backward: Exact = xs.iter().rev().copied().sum();
        assert_eq!(forward.value(), backward.value());
        // Split in three parts, summed apart and merged in another order.
        let parts: Vec<Exact> = xs.chunks(3_333).map(|c| c.iter().copied().sum()).collect();
        let merged: Exact = parts.iter().rev().sum();
        assert_eq!(merged.value(), forward.value());
        // Through the words a rank sends.
        let sent = Exact::from_words(&forward.words());
        assert_eq!(sent.value(), forward.value());
        // A plain f64 sum is near it (the values span 2⁻⁴⁰…2⁴⁰; 10⁴ roundings of at most
        // 2⁻⁵³ of a partial sum below 2⁵⁴).
        let plain: f64 = xs.iter().sum();
        assert!((plain - forward.value()).abs() <= 1e4 * 2f64.powi(54 - 53));
    }

    #[test]
    fn the_parallel_sums_are_the_serial_ones() {
        let xs = values(10_000, 11);
        let [a, b] = par_sums(xs.len(), |i| [xs[i], -3.0 * xs[i] * xs[i]]);
        let serial_a: Exact = xs.iter().copied().sum();
        let serial_b: Exact = xs.iter().map(|x| -3.0 * x * x).sum();
        assert_eq!(a.value(), serial_a.value());
        assert_eq!(b.value(), serial_b.value());
        assert_eq!(par_sum(xs.len(), |i| xs[i]).value(), serial_a.value());
    }

    #[test]
    fn matches_a_sum_in_wide_integers() {
        // Values that are multiples of 2⁻⁶⁰ below 2⁴⁰ are integers below 2¹⁰⁰ in units of
        // 2⁻⁶⁰: their i128 sum is exact, and so must the accumulator's be.
        let xs: Vec<f64> = values(5_000, 3)
            .into_iter()
            .map(|x| (x * 2f64.powi(20)).round() * 2f64.powi(-20))
            .collect();
        let units: i128 = xs.iter().map(|&x| (x * 2f64.powi(60)) as i128).sum();
        let exact = units as f64 * 2f64.powi(-60);
        assert_eq!(xs.iter().copied().sum::<Exact>().value(), exact);
    }

    #[test]
    fn carries_through_a_normalisation_and_saturates_to_infinity() {
        let mut e = Exact::default();
        e.add(0.75);
        // The next additions cross the normalisation that keeps the limbs in range.
        e.pending = NORMALISE_EVERY - 3;
        for _ in 0..10 {
            e.add(f64::from(u32::MAX));
        }
        assert_eq!(e.pending, 7);
        assert_eq!(e.value(), 0.75 + 10.0 * f64::from(u32::MAX));
        let mut big = Exact::default();
        big.add(f64::MAX);
        big.add(f64::MAX);
        assert_eq!(big.value(), f64::INFINITY);
        big.add(-f64::MAX);
        assert_eq!(big.value(), f64::MAX);
    }

    #[test]
    fn non_finite_terms_win() {
        let e: Exact = [1.0, f64::INFINITY, 2.0].into_iter().sum();
        assert_eq!(e.value(), f64::INFINITY);
        let e: Exact = [f64::INFINITY, f64::NEG_INFINITY].into_iter().sum();
        assert!(e.value().is_nan());
        let e: Exact = [1.0, f64::NAN].into_iter().sum();
        assert!(e.value().is_nan());
    }
}
