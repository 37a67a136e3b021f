//! Where the index numbers of a path plot go, so that no two overlap.
//!
//! A path plot marks every [`super::INDEX_EVERY`]-th point and numbers it; where the robot creeps,
//! marks a few pixels apart would pile their numbers into one clump. Labels are placed greedily:
//! the ones that must be read (the selection's ends) first, then the others in path order, each
//! only where its box clears every label already placed, on this path or on any other drawn
//! before it (the other run of a comparison, the ball). Each path has its own side of its points
//! ([`Side`]), so two paths that coincide put their numbers on opposite sides. Pixels only: no
//! drawing here.

/// Height of a label's box, px (12 px text and a pixel either side).
pub(super) const LABEL_H: i32 = 14;
/// Width of one digit of a label, px (sans-serif at 12 px, rounded up).
const DIGIT_W: i32 = 7;

/// A label's box: its top-left corner and size, px.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct LabelBox {
    pub x: i32,
    pub y: i32,
    pub w: i32,
    pub h: i32,
}

impl LabelBox {
    /// Whether two boxes share any pixel.
    pub(super) fn overlaps(&self, o: &LabelBox) -> bool {
        self.x < o.x + o.w && o.x < self.x + self.w && self.y < o.y + o.h && o.y < self.y + self.h
    }
}

/// The side of its point a path's labels sit on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Side {
    /// Right of the point and below it (one path, or the first of two).
    Below,
    /// Right of the point and above it (the second of two, and the ball).
    Above,
}

impl Side {
    /// The label's top-left corner relative to its point.
    fn offset(self) -> (i32, i32) {
        match self {
            Side::Below => (4, 2),
            Side::Above => (4, -LABEL_H - 2),
        }
    }
}

/// One point that may be numbered: its index and where it is drawn, px.
#[derive(Clone, Copy, Debug)]
pub(super) struct Candidate {
    pub index: usize,
    pub at: (i32, i32),
    /// A label that is always drawn (a selection's end), moved to a free side if it can be.
    pub keep: bool,
}

/// A label placed: the index it names and its box (whose top-left corner is where its text goes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Placed {
    pub index: usize,
    pub bx: LabelBox,
    pub keep: bool,
}

/// The box of `index`'s label at `at` on `side`.
fn label_box(index: usize, at: (i32, i32), side: Side) -> LabelBox {
    let digits = index.to_string().len() as i32;
    let (dx, dy) = side.offset();
    LabelBox {
        x: at.0 + dx,
        y: at.1 + dy,
        w: digits * DIGIT_W + 2,
        h: LABEL_H,
    }
}

/// Place the labels of one path on `side`, clear of `taken` (labels already placed, on other
/// paths); the ones placed are added to `taken` and returned. A kept label tries its own side,
/// then the other, then left of its point, and is drawn on its own side if every place is taken.
pub(super) fn place(cands: &[Candidate], side: Side, taken: &mut Vec<LabelBox>) -> Vec<Placed> {
    let mut out = Vec::new();
    let free = |b: &LabelBox, taken: &[LabelBox]| !taken.iter().any(|t| t.overlaps(b));
    for c in cands.iter().filter(|c| c.keep) {
        let own = label_box(c.index, c.at, side);
        let other = label_box(c.index, c.at, flip(side));
        let left = LabelBox {
            x: c.at.0 - own.w - 4,
            ..own
        };
        let bx = [own, other, left]
            .into_iter()
            .find(|b| free(b, taken))
            .unwrap_or(own);
        taken.push(bx);
        out.push(Placed {
            index: c.index,
            bx,
            keep: true,
        });
    }
    for c in cands.iter().filter(|c| !c.keep) {
        let bx = label_box(c.index, c.at, side);
        if free(&bx, taken) {
            taken.push(bx);
            out.push(Placed {
                index: c.index,
                bx,
                keep: false,
            });
        }
    }
    out.sort_by_key(|p| p.index);
    out
}

fn flip(side: Side) -> Side {
    match side {
        Side::Below => Side::Above,
        Side::Above => Side::Below,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn creep(n: usize, step_px: i32) -> Vec<Candidate> {
        (0..n)
            .map(|k| Candidate {
                index: k * 20,
                at: (100 + k as i32 * step_px, 200),
                keep: false,
            })
            .collect()
    }

    fn no_two_overlap(placed: &[LabelBox]) {
        for (i, a) in placed.iter().enumerate() {
            for b in &placed[i + 1..] {
                assert!(!a.overlaps(b), "{a:?} and {b:?} overlap");
            }
        }
    }

    /// The reported clump: points 400 to 1180 a pixel or two apart. Every label placed is at
    /// least a label's width from the others; the selection's ends are kept.
    #[test]
    fn a_creeping_stretch_is_thinned_and_keeps_the_selection_ends() {
        let mut cands = creep(60, 2);
        for c in cands.iter_mut() {
            c.keep = c.index == 400 || c.index == 1180;
        }
        let mut taken = Vec::new();
        let placed = place(&cands, Side::Below, &mut taken);
        no_two_overlap(&taken);
        let indices: Vec<usize> = placed.iter().map(|p| p.index).collect();
        assert!(
            indices.contains(&400) && indices.contains(&1180),
            "{indices:?}"
        );
        assert!(placed.len() < 20, "{} labels on 120 px", placed.len());
        // Where there is room, every mark is numbered.
        let spread = place(&creep(10, 40), Side::Below, &mut Vec::new());
        assert_eq!(spread.len(), 10);
    }

    /// Labels of two paths that coincide sit on opposite sides and never on each other.
    #[test]
    fn coinciding_paths_put_their_labels_apart() {
        let mut taken = Vec::new();
        let a = place(&creep(10, 40), Side::Below, &mut taken);
        let b = place(&creep(10, 40), Side::Above, &mut taken);
        no_two_overlap(&taken);
        assert_eq!((a.len(), b.len()), (10, 10));
        assert!(a[3].bx.y > b[3].bx.y);
    }

    /// Two kept labels on one point: the second goes to a free side.
    #[test]
    fn kept_labels_move_to_a_free_side() {
        let cands = [
            Candidate {
                index: 40,
                at: (50, 50),
                keep: true,
            },
            Candidate {
                index: 42,
                at: (51, 50),
                keep: true,
            },
        ];
        let mut taken = Vec::new();
        let placed = place(&cands, Side::Below, &mut taken);
        assert_eq!(placed.len(), 2);
        no_two_overlap(&taken);
    }
}
