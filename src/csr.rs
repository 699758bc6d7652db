//! Compressed sparse rows: the one layout of every per-vertex table of
//! variable length (one-rings, the near hits' samples, emitter
//! coefficients, the radiosity correction's weights, ...). Row `i` holds
//! `items[offsets[i]..offsets[i + 1]]`; `offsets` rises from 0 to
//! `items.len()` over `rows + 1` entries, or is empty for a table that
//! holds nothing anywhere.
//!
//! [`RowBuilder`] fills a table row by row (the rows of a batch of
//! vertices come out of a parallel map in order); [`Csr::from_pairs`]
//! groups `(row, item)` pairs; [`check_offsets`] is the validation every
//! CSR-shaped table (also those whose items live in several parallel
//! arrays, such as the links' packed groups) runs from its `validate()`.

/// Rows of items of type `T`.
#[derive(Clone, Debug, PartialEq)]
pub struct Csr<T = u32> {
    /// Row offsets: row `r` is `items[offsets[r]..offsets[r + 1]]` (row count plus one entries).
    pub offsets: Vec<u32>,
    /// The items of every row, row after row.
    pub items: Vec<T>,
}

impl<T> Default for Csr<T> {
    fn default() -> Self {
        Csr { offsets: Vec::new(), items: Vec::new() }
    }
}

impl<T> Csr<T> {
    /// `rows` empty rows.
    pub fn empty_rows(rows: usize) -> Self {
        Csr { offsets: vec![0; rows + 1], items: Vec::new() }
    }

    /// Row `i`.
    #[inline]
    pub fn row(&self, i: usize) -> &[T] {
        &self.items[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// The item range of row `i`.
    #[inline]
    #[cfg(any(test, feature = "internals"))]
    pub fn range(&self, i: usize) -> std::ops::Range<usize> {
        self.offsets[i] as usize..self.offsets[i + 1] as usize
    }

    /// Rows (0 for an empty table).
    pub fn rows(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// True when the table has no offsets (it holds nothing anywhere).
    pub fn is_empty(&self) -> bool {
        self.offsets.is_empty()
    }

    /// Bytes of the offsets and items.
    pub fn bytes(&self) -> u64 {
        (std::mem::size_of_val(self.offsets.as_slice()) + std::mem::size_of_val(self.items.as_slice())) as u64
    }

    /// Checks the layout against `rows` rows (an empty table passes when it
    /// has no items) and every item with `item` (its row and the item).
    pub fn validate(&self, rows: usize, item: impl Fn(usize, &T) -> Result<(), String>) -> Result<(), String> {
        if self.offsets.is_empty() {
            return if self.items.is_empty() { Ok(()) } else { Err("items without offsets".into()) };
        }
        check_offsets(&self.offsets, rows, self.items.len())?;
        for r in 0..rows {
            for it in self.row(r) {
                item(r, it)?;
            }
        }
        Ok(())
    }
}

impl<T: Copy> Csr<T> {
    /// Builds rows from `(row, item)` pairs; items keep the order given.
    pub fn from_pairs(rows: usize, pairs: &[(u32, T)]) -> Self {
        let mut offsets = vec![0u32; rows + 1];
        for &(r, _) in pairs {
            offsets[r as usize + 1] += 1;
        }
        for i in 0..rows {
            offsets[i + 1] += offsets[i];
        }
        let mut fill = offsets.clone();
        // Every slot is written once below; the first item only sizes the vector.
        let mut items = pairs.first().map_or_else(Vec::new, |p| vec![p.1; pairs.len()]);
        for &(r, it) in pairs {
            items[fill[r as usize] as usize] = it;
            fill[r as usize] += 1;
        }
        Self { offsets, items }
    }
}

/// Fills a [`Csr`] row by row.
#[derive(Debug)]
pub struct RowBuilder<T> {
    csr: Csr<T>,
}

impl<T> RowBuilder<T> {
    /// A table to fill with rows, the first starting now.
    pub fn new() -> Self {
        RowBuilder { csr: Csr { offsets: vec![0], items: Vec::new() } }
    }

    /// Adds an item to the current row.
    #[inline]
    #[cfg(any(test, feature = "internals"))]
    pub fn push(&mut self, item: T) {
        self.csr.items.push(item);
    }

    /// Adds items to the current row.
    pub fn extend(&mut self, items: impl IntoIterator<Item = T>) {
        self.csr.items.extend(items);
    }

    /// Closes the current row (the next pushes go to the next row).
    #[inline]
    pub fn end_row(&mut self) {
        self.csr.offsets.push(self.csr.items.len() as u32);
    }

    /// Items pushed so far, all rows.
    #[cfg(any(test, feature = "internals"))]
    pub fn len(&self) -> usize {
        self.csr.items.len()
    }

    /// True when no item was pushed.
    #[cfg(any(test, feature = "internals"))]
    pub fn is_empty(&self) -> bool {
        self.csr.items.is_empty()
    }

    /// The table of the closed rows.
    pub fn finish(self) -> Csr<T> {
        self.csr
    }
}

impl<T> Default for RowBuilder<T> {
    fn default() -> Self {
        Self::new()
    }
}

/// Checks the offsets of a CSR layout: `rows + 1` offsets rising from 0 to
/// `entries`.
pub fn check_offsets(offsets: &[u32], rows: usize, entries: usize) -> Result<(), String> {
    if offsets.len() != rows + 1
        || offsets[0] != 0
        || offsets.windows(2).any(|w| w[0] > w[1])
        || offsets[rows] as usize != entries
    {
        return Err(format!("{} offsets do not rise from 0 to {entries} entries over {rows} rows", offsets.len()));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pairs_and_rows_build_the_same_table() {
        let pairs = [(2u32, 7u32), (0, 1), (2, 8), (0, 2)];
        let a = Csr::from_pairs(3, &pairs);
        let mut b = RowBuilder::new();
        b.extend([1, 2]);
        b.end_row();
        b.end_row();
        b.extend([7, 8]);
        b.end_row();
        let b = b.finish();
        assert_eq!(a, b);
        assert_eq!(a.row(0), &[1, 2]);
        assert!(a.row(1).is_empty());
        assert_eq!(a.rows(), 3);
        a.validate(3, |_, &x| if x < 9 { Ok(()) } else { Err(format!("{x}")) }).unwrap();
    }

    #[test]
    fn validation_catches_bad_offsets_and_items() {
        let mut a = Csr::from_pairs(2, &[(0u32, 5u32), (1, 6)]);
        assert!(a.validate(3, |_, _| Ok(())).is_err(), "wrong row count");
        assert!(a.validate(2, |_, &x| if x == 6 { Err("six".into()) } else { Ok(()) }).is_err());
        a.offsets[1] = 3;
        assert!(a.validate(2, |_, _| Ok(())).is_err(), "offsets not rising");
        let empty: Csr<u32> = Csr::default();
        assert!(empty.validate(10, |_, _| Ok(())).is_ok());
        let orphan = Csr { offsets: vec![], items: vec![1u32] };
        assert!(orphan.validate(0, |_, _| Ok(())).is_err());
    }
}
