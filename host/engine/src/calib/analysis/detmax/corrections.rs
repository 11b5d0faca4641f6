//! The rank-r corrections of DETMAX's dispersions: what each pose added or
//! dropped since the last pass changes in every candidate's `G_c`, and the
//! products with the candidates' rows that apply them.

use nalgebra::DMatrix;

use super::Pool;

/// The rank-r changes of `M⁻¹` made since the dispersions were last
/// written: a pose added (`sign` = 1) or dropped (−1) takes
/// `sign · K̃ K̃ᵀ` from `M⁻¹` and `sign · (A_c K̃)(A_c K̃)ᵀ` from each
/// dispersion.
#[derive(Clone, Debug, Default)]
pub(super) struct Corrections {
    /// The `K̃` side by side, by groups of four columns (zeros past the
    /// last): group `g`'s row `k` at `m·g + k`. Four columns at a time fill
    /// two vector registers, and no sum is reduced across lanes.
    groups: Vec<[f64; 4]>,
    /// The same columns one after the other (`m × w`, column-major), for
    /// the pass over every candidate.
    columns: Vec<f64>,
    /// Each column's sign.
    signs: Vec<f64>,
}

impl Corrections {
    pub(super) fn is_empty(&self) -> bool {
        self.signs.is_empty()
    }

    /// Columns of `K̃` collected (`r` per pose added or dropped).
    pub(super) fn len(&self) -> usize {
        self.signs.len()
    }

    /// Whether every correction is an addition: each then only shrinks
    /// the dispersions (`G_c − Σ p pᵀ`), and with them every gain.
    pub(super) fn only_additions(&self) -> bool {
        self.signs.iter().all(|&s| s > 0.0)
    }

    pub(super) fn push(&mut self, k: &DMatrix<f64>, sign: f64) {
        let m = k.nrows();
        self.columns.extend_from_slice(k.as_slice());
        for col in k.column_iter() {
            let lane = self.signs.len() % 4;
            if lane == 0 {
                self.groups.resize(self.groups.len() + m, [0.0; 4]);
            }
            let start = self.groups.len() - m;
            for (g, v) in self.groups[start..].iter_mut().zip(col.iter()) {
                g[lane] = *v;
            }
            self.signs.push(sign);
        }
    }

    /// `A_c K̃` of every candidate at once (`r·C × w'`: candidate `c`'s row
    /// `i` is row `r·c + i`), `None` when there is nothing to correct.
    ///
    /// One product `stacked · K̃` through nalgebra's blocked kernel
    /// (matrixmultiply, vectorised for the machine it runs on), which it
    /// uses only above 5 columns: fewer are padded with zeros (`w'`). The
    /// kernel first copies the candidates' rows into panels of a few rows;
    /// from the column-major `stacked` that copy reads each panel's rows
    /// side by side, where from `stacked_t` it would gather them across
    /// columns, and it was most of the time of a pass.
    pub(super) fn products(&self, pool: &Pool) -> Option<DMatrix<f64>> {
        if self.is_empty() {
            return None;
        }
        Some(&pool.stacked * self.padded(pool.m()))
    }

    /// `A_c K̃` of the candidates `some` only (candidate `some[s]`'s row
    /// `i` is row `r·s + i`), entry for entry the numbers of
    /// [`Corrections::products`]: the same kernel, padded with zero rows to
    /// the 6 it needs.
    pub(super) fn products_of(&self, pool: &Pool, some: &[usize]) -> DMatrix<f64> {
        let (m, r) = (pool.m(), pool.r);
        let mut rows = DMatrix::zeros((r * some.len()).max(6), m);
        for (s, &c) in some.iter().enumerate() {
            for (i, row) in pool.rows(c).chunks_exact(m).enumerate() {
                for (k, v) in row.iter().enumerate() {
                    rows[(r * s + i, k)] = *v;
                }
            }
        }
        rows * self.padded(m)
    }

    /// The `K̃` as an `m × w'` matrix, zero columns past the last.
    pub(super) fn padded(&self, m: usize) -> DMatrix<f64> {
        let w = self.signs.len();
        let mut k = DMatrix::zeros(m, w.max(6));
        k.columns_mut(0, w)
            .copy_from(&DMatrix::from_column_slice(m, w, &self.columns));
        k
    }

    /// `g` corrected into `out` for the candidate whose rows are block `c`
    /// of `products` ([`Corrections::products`] or [`Corrections::products_of`]).
    pub(super) fn correct(
        &self,
        g: &[f64],
        products: &DMatrix<f64>,
        c: usize,
        r: usize,
        out: &mut [f64],
    ) {
        out.copy_from_slice(g);
        let p = |i: usize, j: usize| products[(r * c + i, j)];
        for (j, &sign) in self.signs.iter().enumerate() {
            for b in 0..r {
                let pb = sign * p(b, j);
                for a in 0..r {
                    out[a + b * r] -= p(a, j) * pb;
                }
            }
        }
    }

    /// `g` corrected for candidate `rows` (its `r` rows of `m`) into
    /// `out`, for a few candidates; `p` is scratch for `A_c K̃`.
    pub(super) fn apply(
        &self,
        g: &[f64],
        rows: &[f64],
        r: usize,
        p: &mut Vec<[f64; 4]>,
        out: &mut [f64],
    ) {
        out.copy_from_slice(g);
        if self.is_empty() {
            return;
        }
        let m = rows.len() / r;
        // p[group · r + row] = row · K̃'s columns of the group; three rows
        // at a time, six independent sums.
        p.clear();
        for group in self.groups.chunks_exact(m) {
            let threes = rows.chunks_exact(3 * m);
            let rest = threes.remainder();
            for three in threes {
                let (a0, rest) = three.split_at(m);
                let (a1, a2) = rest.split_at(m);
                let mut acc = [[0.0; 4]; 3];
                for k in 0..m {
                    let kk = &group[k];
                    for l in 0..4 {
                        acc[0][l] += a0[k] * kk[l];
                        acc[1][l] += a1[k] * kk[l];
                        acc[2][l] += a2[k] * kk[l];
                    }
                }
                p.extend(acc);
            }
            // A block is 3 rows per load and target; any other count ends here.
            for a in rest.chunks_exact(m) {
                let mut acc = [0.0; 4];
                for (x, kk) in a.iter().zip(group) {
                    for l in 0..4 {
                        acc[l] += x * kk[l];
                    }
                }
                p.push(acc);
            }
        }
        for (j, &sign) in self.signs.iter().enumerate() {
            let (group, lane) = (j / 4, j % 4);
            let pj = |row: usize| p[group * r + row][lane];
            for b in 0..r {
                let pb = sign * pj(b);
                for a in 0..r {
                    out[a + b * r] -= pj(a) * pb;
                }
            }
        }
    }
}
