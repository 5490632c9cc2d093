//! Recordings made partial for tests (feature `recordings`).

/// `rec` without the columns at `columns` (indices into its taxel ids, any order).
pub fn without_columns(rec: &skin_core::Recording, columns: &[usize]) -> skin_core::Recording {
    let mut gone = columns.to_vec();
    gone.sort_unstable();
    gone.dedup();
    let mut out = rec.clone();
    for &c in gone.iter().rev() {
        if c < out.taxel_ids.len() {
            out.taxel_ids.remove(c);
            for f in &mut out.frames {
                f.values.remove(c);
            }
        }
    }
    out
}
