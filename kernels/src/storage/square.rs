//! An n × n matrix, column-major, on the caller's slice.

use core::ops::{Index, IndexMut};

/// An n × n matrix stored column-major in the caller's slice (n² long): `a[c][r]` is row
/// r of column c, as in a `[[T; n]; n]` array (the fixed-N storage's) or a `Vec` of n²
/// (the runtime-N storage's). The step reads every matrix through it.
#[derive(Debug)]
pub struct Square<'a, T> {
    data: &'a mut [T],
    n: usize,
}

impl<'a, T: Copy> Square<'a, T> {
    /// The n × n matrix in the first n² values of `data` (`None` when it is shorter).
    pub fn new(data: &'a mut [T], n: usize) -> Option<Self> {
        let data = data.get_mut(..n * n)?;
        Some(Square { data, n })
    }

    /// The 0 × 0 matrix.
    pub fn empty() -> Self {
        Square {
            data: &mut [],
            n: 0,
        }
    }

    /// The D × D array `a` (`a[c][r]` as here).
    #[inline(always)]
    pub fn of_array<const D: usize>(a: &'a mut [[T; D]; D]) -> Self {
        Square {
            data: a.as_flattened_mut(),
            n: D,
        }
    }

    /// n.
    #[inline(always)]
    pub fn n(&self) -> usize {
        self.n
    }

    /// The values, column by column (n² long).
    #[inline(always)]
    pub fn as_slice(&self) -> &[T] {
        self.data
    }

    /// The values, column by column (n² long).
    #[inline(always)]
    pub fn as_mut_slice(&mut self) -> &mut [T] {
        self.data
    }

    /// The same matrix, borrowed again for a shorter time.
    #[inline(always)]
    pub fn reborrow(&mut self) -> Square<'_, T> {
        Square {
            data: self.data,
            n: self.n,
        }
    }

    /// Set every value to `x`.
    pub fn fill(&mut self, x: T) {
        self.data.fill(x);
    }

    /// Copy the values of `other` (the same n).
    pub fn copy_from(&mut self, other: &Square<'_, T>) {
        self.data.copy_from_slice(other.data);
    }

    /// Columns `k` and `c` (k < c) at once: `k` to read, `c` to write.
    #[inline(always)]
    pub fn column_pair(&mut self, k: usize, c: usize) -> (&[T], &mut [T]) {
        let n = self.n;
        let (left, right) = self.data.split_at_mut(c * n);
        (&left[k * n..k * n + n], &mut right[..n])
    }

    /// Swap rows `a` and `b` in every column.
    pub fn swap_rows(&mut self, a: usize, b: usize) {
        for col in self.data.chunks_exact_mut(self.n) {
            col.swap(a, b);
        }
    }
}

impl<T> Index<usize> for Square<'_, T> {
    type Output = [T];
    #[inline(always)]
    fn index(&self, c: usize) -> &[T] {
        &self.data[c * self.n..(c + 1) * self.n]
    }
}

impl<T> IndexMut<usize> for Square<'_, T> {
    #[inline(always)]
    fn index_mut(&mut self, c: usize) -> &mut [T] {
        &mut self.data[c * self.n..(c + 1) * self.n]
    }
}
