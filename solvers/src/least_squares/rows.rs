//! Residual rows with windowed gradients: the sparse Jacobian format of
//! banded least-squares problems.

/// A list of scalar rows, each with a key, a value and its gradient over a
/// contiguous window of variables `first .. first + width`. Clearing keeps
/// the storage, so refilling it allocates nothing once it has grown.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RowBlock {
    values: Vec<f64>,
    keys: Vec<u64>,
    first: Vec<usize>,
    /// Row `r`'s gradient is `jac[offsets[r] .. offsets[r + 1]]`.
    offsets: Vec<usize>,
    jac: Vec<f64>,
}

impl RowBlock {
    /// An empty block with room for `rows` rows and `entries` gradient
    /// entries.
    pub fn with_capacity(rows: usize, entries: usize) -> RowBlock {
        let mut offsets = Vec::with_capacity(rows + 1);
        offsets.push(0);
        RowBlock {
            values: Vec::with_capacity(rows),
            keys: Vec::with_capacity(rows),
            first: Vec::with_capacity(rows),
            offsets,
            jac: Vec::with_capacity(entries),
        }
    }

    /// Removes every row, keeping the storage.
    pub fn clear(&mut self) {
        self.values.clear();
        self.keys.clear();
        self.first.clear();
        self.offsets.clear();
        self.offsets.push(0);
        self.jac.clear();
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// Appends a row with `key` and `value` whose gradient covers variables
    /// `first .. first + width`, and returns that gradient (zeroed) to fill.
    pub fn push(&mut self, key: u64, value: f64, first: usize, width: usize) -> &mut [f64] {
        if self.offsets.is_empty() {
            self.offsets.push(0);
        }
        self.values.push(value);
        self.keys.push(key);
        self.first.push(first);
        let start = self.jac.len();
        self.jac.resize(start + width, 0.0);
        self.offsets.push(start + width);
        &mut self.jac[start..]
    }

    /// Value of row `r`.
    pub fn value(&self, r: usize) -> f64 {
        self.values[r]
    }

    /// Every row's value.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Key of row `r`.
    pub fn key(&self, r: usize) -> u64 {
        self.keys[r]
    }

    /// Row `r`'s gradient: the first variable and the entries.
    pub fn gradient(&self, r: usize) -> (usize, &[f64]) {
        (self.first[r], &self.jac[self.offsets[r]..self.offsets[r + 1]])
    }

    /// Largest window width of any row and last variable touched plus one
    /// (0 and 0 when empty), in one pass.
    pub(crate) fn extent(&self) -> (usize, usize) {
        let (mut width, mut end) = (0, 0);
        for (w, first) in self.offsets.windows(2).zip(&self.first) {
            width = width.max(w[1] - w[0]);
            end = end.max(first + w[1] - w[0]);
        }
        (width, end)
    }

    /// Whether any value or gradient entry is NaN or infinite.
    pub(crate) fn has_non_finite(&self) -> bool {
        !(all_finite(&self.values) && all_finite(&self.jac))
    }
}

/// Whether every entry is finite, without a branch per entry: `v · 0` is
/// NaN exactly for NaN and infinite `v`, and a NaN survives the sum.
fn all_finite(values: &[f64]) -> bool {
    let chunks = values.chunks_exact(4);
    let mut acc = chunks.remainder().iter().fold(0.0, |a, v| a + v * 0.0);
    let mut lanes = [0.0; 4];
    for c in chunks {
        for k in 0..4 {
            lanes[k] += c[k] * 0.0;
        }
    }
    acc += (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
    !acc.is_nan()
}

/// The rows of one evaluation: costs `r` (minimised as `Σ r²`), equality
/// constraints `h = 0` and inequality constraints `g ≤ 0`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Residuals {
    pub cost: RowBlock,
    pub equality: RowBlock,
    pub inequality: RowBlock,
}

impl Residuals {
    /// Removes every row of every block, keeping the storage.
    pub fn clear(&mut self) {
        self.cost.clear();
        self.equality.clear();
        self.inequality.clear();
    }

    /// `Σ r²` over the cost rows.
    pub fn cost_value(&self) -> f64 {
        self.cost.values().iter().map(|r| r * r).sum()
    }

    /// `max |h|` (0 without equality rows).
    pub fn equality_violation(&self) -> f64 {
        self.equality.values().iter().fold(0.0, |m, h| m.max(h.abs()))
    }

    /// `max(0, max g)` (0 without inequality rows).
    pub fn inequality_violation(&self) -> f64 {
        self.inequality.values().iter().fold(0.0, |m, &g| m.max(g))
    }

    pub(crate) fn blocks(&self) -> [&RowBlock; 3] {
        [&self.cost, &self.equality, &self.inequality]
    }
}
