//! From a run-time number of elements N to code monomorphised for it: the sizes with
//! generated kernels ([`superhelix_generated::sizes::CHECKED_IN_SIZES`]), each with its
//! const parameters D = 3N, E = N + 1 and B = ⌊D/2⌋.
//!
//! Everything in this crate that needs a size goes through [`visit_size`], so that a
//! dispatch provided by `superhelix-generated` itself can replace this one in one place.

/// Code run for one number of elements with all of its sizes as constants.
pub trait SizeVisitor {
    /// What the visit returns.
    type Output;
    /// The visit at N elements, D = 3N coordinates, E = N + 1 element ends and B = ⌊D/2⌋
    /// columns of the kept eigenbasis.
    fn visit<const N: usize, const D: usize, const E: usize, const B: usize>(self) -> Self::Output;
}

macro_rules! sizes {
    ($($n:literal => ($d:literal, $e:literal, $b:literal)),* $(,)?) => {
        /// The numbers of elements [`visit_size`] dispatches to, in increasing order.
        pub const SIZES: &[usize] = &[$($n),*];

        /// `visitor` run at `n` elements, or `None` when there is no generated code for
        /// `n`.
        pub fn visit_size<V: SizeVisitor>(n: usize, visitor: V) -> Option<V::Output> {
            match n {
                $($n => Some(visitor.visit::<$n, $d, $e, $b>()),)*
                _ => None,
            }
        }
    };
}

sizes!(
    1 => (3, 2, 1),
    2 => (6, 3, 3),
    3 => (9, 4, 4),
    4 => (12, 5, 6),
    5 => (15, 6, 7),
    6 => (18, 7, 9),
    8 => (24, 9, 12),
    10 => (30, 11, 15),
    12 => (36, 13, 18),
    15 => (45, 16, 22),
    20 => (60, 21, 30),
);

#[cfg(test)]
mod tests {
    use super::*;

    struct Check;
    impl SizeVisitor for Check {
        type Output = (usize, usize, usize, usize);
        fn visit<const N: usize, const D: usize, const E: usize, const B: usize>(
            self,
        ) -> Self::Output {
            (N, D, E, B)
        }
    }

    #[test]
    fn sizes_are_the_checked_in_ones_with_their_constants() {
        assert_eq!(SIZES, &superhelix_generated::sizes::CHECKED_IN_SIZES[..]);
        for &n in SIZES {
            assert_eq!(visit_size(n, Check), Some((n, 3 * n, n + 1, 3 * n / 2)));
        }
        assert_eq!(visit_size(0, Check), None);
        assert_eq!(visit_size(7, Check), None);
    }
}
