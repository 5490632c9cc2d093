//! Where a hand-part segmenter goes wrong (thesis Ch. 4.4, Table 4.8's scores looked into): on
//! the seams where two fingers meet in one imprint, on whole parts given a neighbour's name, or
//! on the hand taken for the other side. `skin eval` reports these; they are plain functions on
//! label images (row-major, 0 = background, the [`Part`] labels) for any other tool too.

use crate::parts::Part;

/// The labels `truth` would have if the hand were the mirror image of itself, a right hand for a
/// left one: the same pixels, with the fingers in the other order (index and pinkie swap, middle
/// and ring). A segmenter that takes a hand for the other side gets this right instead.
pub fn mirror_hand(truth: &[u8]) -> Vec<u8> {
    let swap = |l: u8| match Part::from_label(l) {
        Some(Part::Index) => Part::Pinkie as u8,
        Some(Part::Pinkie) => Part::Index as u8,
        Some(Part::Middle) => Part::Ring as u8,
        Some(Part::Ring) => Part::Middle as u8,
        _ => l,
    };
    truth.iter().map(|&l| swap(l)).collect()
}

/// Bins of a part pixel's distance to the nearest pixel of another part (in pixels, 8-connected:
/// 1 for a pixel on a seam): (name, largest distance in the bin). The last bin takes the pixels
/// with no other part within [`SEAM_REACH`], and the pixels of a hand with one part only.
pub const SEAM_BINS: [(&str, u8); 6] = [
    ("1", 1),
    ("2", 2),
    ("3", 3),
    ("4-5", 5),
    ("6-7", 7),
    ("farther", u8::MAX),
];

/// How far [`seam_distance`] looks.
pub const SEAM_REACH: u8 = 7;

/// For each pixel of `truth` with a part, the Chebyshev distance to the nearest pixel of another
/// part (background does not count), or `u8::MAX` if none lies within [`SEAM_REACH`]; 0 for
/// background pixels. Where two fingers meet, the image shows one imprint: this says how much of
/// the error sits near such seams rather than on whole parts mistaken.
pub fn seam_distance(truth: &[u8], rows: usize, cols: usize) -> Vec<u8> {
    let reach = isize::from(SEAM_REACH);
    let at = |y: isize, x: isize| -> u8 {
        if y < 0 || x < 0 || y >= rows as isize || x >= cols as isize {
            0
        } else {
            truth.get(y as usize * cols + x as usize).copied().unwrap_or(0)
        }
    };
    let mut out = vec![0u8; truth.len()];
    for (i, d) in out.iter_mut().enumerate().take(rows * cols) {
        let l = truth[i];
        if l == 0 {
            continue;
        }
        let (r, c) = ((i / cols) as isize, (i % cols) as isize);
        *d = (1..=reach)
            .find(|&k| {
                // The ring of pixels at distance exactly k.
                (-k..=k).any(|e| {
                    [(r - k, c + e), (r + k, c + e), (r + e, c - k), (r + e, c + k)]
                        .iter()
                        .any(|&(y, x)| {
                            let m = at(y, x);
                            m != 0 && m != l
                        })
                })
            })
            .map_or(u8::MAX, |k| k as u8);
    }
    out
}

/// How a segmenter named the part regions of its images: a region is a set of 8-connected
/// pixels with the same true part, and it is named wrong when most of its pixels carry one other
/// part's label. Its wrong pixels are then a finger taken for its neighbour (or the hand for the
/// other side), not a border drawn in the wrong place.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Naming {
    /// Part regions.
    pub regions: u64,
    /// Regions named wrong.
    pub misnamed: u64,
    /// Part pixels predicted wrong.
    pub wrong: u64,
    /// Of those, the pixels in regions named wrong.
    pub wrong_in_misnamed: u64,
}

impl Naming {
    /// Adds another image's counts.
    pub fn add(&mut self, other: &Naming) {
        self.regions += other.regions;
        self.misnamed += other.misnamed;
        self.wrong += other.wrong;
        self.wrong_in_misnamed += other.wrong_in_misnamed;
    }
}

/// Names each part region of `truth` by the label most of its pixels got in `predicted` (a tie
/// with the true part goes to the true part), and returns the counts with a copy of `predicted`
/// in which each region named wrong has its name corrected: its pixels that carry the wrong
/// name get the true one, the rest keep theirs.
pub fn name_regions(truth: &[u8], predicted: &[u8], rows: usize, cols: usize) -> (Naming, Vec<u8>) {
    let n = (rows * cols).min(truth.len()).min(predicted.len());
    let mut renamed = predicted.to_vec();
    let mut seen = vec![false; n];
    let mut naming = Naming::default();
    let (mut region, mut stack) = (Vec::new(), Vec::new());
    for start in 0..n {
        let part = truth[start];
        if part == 0 || seen[start] {
            continue;
        }
        // Flood fill over the 8 neighbours with the same true part.
        region.clear();
        stack.push(start);
        seen[start] = true;
        while let Some(i) = stack.pop() {
            region.push(i);
            let (r, c) = (i / cols, i % cols);
            for y in r.saturating_sub(1)..(r + 2).min(rows) {
                for x in c.saturating_sub(1)..(c + 2).min(cols) {
                    let j = y * cols + x;
                    if j < n && !seen[j] && truth[j] == part {
                        seen[j] = true;
                        stack.push(j);
                    }
                }
            }
        }
        let mut votes = [0u64; 256];
        for &i in &region {
            votes[usize::from(predicted[i])] += 1;
        }
        let own = votes[usize::from(part)];
        let (name, most) = votes
            .iter()
            .enumerate()
            .max_by_key(|&(_, &v)| v)
            .map_or((usize::from(part), own), |(l, &v)| (l, v));
        let wrong = region.len() as u64 - own;
        naming.regions += 1;
        naming.wrong += wrong;
        // A tie with the true part keeps the true name.
        if name != usize::from(part) && most > own {
            naming.misnamed += 1;
            naming.wrong_in_misnamed += wrong;
            for &i in &region {
                if usize::from(predicted[i]) == name {
                    renamed[i] = part;
                }
            }
        }
    }
    (naming, renamed)
}

/// `truth` with every pixel that has a differently labelled 8-neighbour set to 0 (unscored).
pub fn off_borders(truth: &[u8], rows: usize, cols: usize) -> Vec<u8> {
    let mut out = truth.to_vec();
    for r in 0..rows {
        for c in 0..cols {
            let l = truth[r * cols + c];
            let seam = (r.saturating_sub(1)..(r + 2).min(rows))
                .any(|y| (c.saturating_sub(1)..(c + 2).min(cols)).any(|x| truth[y * cols + x] != l));
            if seam {
                out[r * cols + c] = 0;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_region_mostly_given_another_name_is_named_wrong_and_only_that_name_is_corrected() {
        // Two rows: index (2) in columns 0-2, middle (3) in 3-5, background in 6.
        let truth: Vec<u8> = (0..14)
            .map(|i| match i % 7 {
                0..=2 => 2,
                3..=5 => 3,
                _ => 0,
            })
            .collect();
        // The index region is called middle (4 pixels) and ring (1), right once; the middle
        // region is right but for one border pixel called index. Background is not scored.
        let predicted = [3, 3, 2, 3, 3, 2, 6, 3, 4, 3, 3, 3, 3, 0];
        let (naming, renamed) = name_regions(&truth, &predicted, 2, 7);
        assert_eq!(
            naming,
            Naming {
                regions: 2,
                misnamed: 1,
                wrong: 6,
                wrong_in_misnamed: 5,
            }
        );
        // The index pixels called middle become index; the one called ring stays wrong.
        assert_eq!(renamed, [2, 2, 2, 3, 3, 2, 6, 2, 4, 2, 3, 3, 3, 0]);
    }

    #[test]
    fn regions_are_8_connected_and_a_tie_keeps_the_true_name() {
        // Two thumb pixels touching at a corner make one region; a third, apart, another.
        let truth = [1u8, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 1];
        let predicted = [1u8, 0, 0, 0, 6, 0, 0, 0, 0, 0, 0, 6];
        let (naming, renamed) = name_regions(&truth, &predicted, 3, 4);
        // The pair is one right and one palm: a tie, named right. The lone pixel is named wrong.
        assert_eq!(
            naming,
            Naming {
                regions: 2,
                misnamed: 1,
                wrong: 2,
                wrong_in_misnamed: 1,
            }
        );
        assert_eq!(renamed[4], 6);
        assert_eq!(renamed[11], 1);
        // A prediction that is right everywhere has nothing named wrong.
        assert_eq!(name_regions(&truth, &truth, 3, 4).0.misnamed, 0);
    }

    #[test]
    fn off_borders_unscores_both_sides_of_a_seam_and_nothing_else() {
        // Two parts side by side (columns 0-2 part 1, 3-5 part 2) on 4 rows; the image's edge
        // is no seam.
        let truth: Vec<u8> = (0..24).map(|i| if i % 6 < 3 { 1 } else { 2 }).collect();
        let kept = off_borders(&truth, 4, 6);
        let expected: Vec<u8> = (0..24)
            .map(|i| match i % 6 {
                2 | 3 => 0,
                c if c < 2 => 1,
                _ => 2,
            })
            .collect();
        assert_eq!(kept, expected);
        // A part pixel next to background (0) is on a seam too.
        let mut lone = vec![0u8; 9];
        lone[4] = 6;
        assert_eq!(off_borders(&lone, 3, 3), vec![0; 9]);
        assert_eq!(off_borders(&[3; 12], 3, 4), vec![3; 12]);
    }

    #[test]
    fn the_mirror_hand_swaps_the_fingers_in_order_and_keeps_the_rest() {
        // background, thumb, index, middle, ring, pinkie, palm, and a label out of range
        assert_eq!(
            mirror_hand(&[0, 1, 2, 3, 4, 5, 6, 9]),
            vec![0, 1, 5, 4, 3, 2, 6, 9]
        );
        let row = [2u8, 2, 3, 3, 0, 4, 5, 6, 1];
        assert_eq!(mirror_hand(&mirror_hand(&row)), row);
    }

    #[test]
    fn seam_distance_counts_pixels_to_the_nearest_other_part_not_to_background() {
        // One row: background, three thumb pixels, three index pixels, background.
        let row = [0u8, 1, 1, 1, 2, 2, 2, 0];
        assert_eq!(seam_distance(&row, 1, 8), vec![0, 3, 2, 1, 1, 2, 3, 0]);
        // Diagonal neighbours are at distance 1; a lone part has no seam.
        let diag = [1u8, 0, 0, 0, 0, 0, 0, 0, 2];
        assert_eq!(seam_distance(&diag, 3, 3), vec![2, 0, 0, 0, 0, 0, 0, 0, 2]);
        assert_eq!(seam_distance(&[6; 6], 2, 3), vec![u8::MAX; 6]);
        // Beyond the reach of 7 pixels: none.
        let mut far = vec![3u8; 10];
        far[9] = 4;
        assert_eq!(seam_distance(&far, 1, 10)[..3], [u8::MAX, u8::MAX, 7]);
    }
}
