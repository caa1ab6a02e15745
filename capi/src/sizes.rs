//! From a run-time number of elements N to code monomorphised for it: the dispatch of
//! `superhelix-generated` ([`visit_size`] over [`SizeVisitor`]), which covers the
//! checked-in sizes and those `SUPERHELIX_N` added when it was built, each with its
//! const parameters D = 3N, E = N + 1 and B = ⌊D/2⌋.
//!
//! Everything in this crate that needs a size goes through [`visit_size`].

pub use superhelix_generated::{visit_size, SizeVisitor};

/// The numbers of elements [`visit_size`] dispatches to, in increasing order.
pub const SIZES: &[usize] = &superhelix_generated::fixed::SIZES;

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
    fn sizes_are_those_of_the_build_with_their_constants() {
        let checked_in = superhelix_generated::sizes::CHECKED_IN_SIZES;
        assert!(checked_in.iter().all(|n| SIZES.contains(n)));
        for &n in SIZES {
            assert_eq!(visit_size(n, Check), Some((n, 3 * n, n + 1, 3 * n / 2)));
        }
        assert_eq!(visit_size(0, Check), None);
        assert_eq!(visit_size(201, Check), None);
    }
}
