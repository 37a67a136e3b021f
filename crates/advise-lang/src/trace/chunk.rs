//! Chunks: validated half-open ranges of a trace's point indices, what advice and critiques
//! apply to.

use std::ops::Range;

use miette::Diagnostic;
use serde::{Deserialize, Serialize};
use thiserror::Error;

pub use crate::syntax::command::{PointRange, RangeStart};

/// A contiguous, half-open range `start..end` of point indices of one trace.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Chunk {
    pub start: usize,
    pub end: usize,
}

impl Chunk {
    /// A chunk of a trace of `len` points; errors when reversed or out of range.
    /// An empty chunk (`start == end`) is allowed: applying advice to it changes nothing.
    pub fn new(start: usize, end: usize, len: usize) -> Result<Chunk, ChunkError> {
        if start > end {
            return Err(ChunkError::Reversed { start, end });
        }
        if end > len {
            return Err(ChunkError::OutOfRange { start, end, len });
        }
        Ok(Chunk { start, end })
    }

    /// The whole of a trace of `len` points.
    pub fn all(len: usize) -> Chunk {
        Chunk { start: 0, end: len }
    }

    /// Points in the chunk. The fields are public (and deserialised), so a reversed chunk can
    /// exist; it holds no points, as its [`Chunk::range`] is empty.
    pub fn len(&self) -> usize {
        self.end.saturating_sub(self.start)
    }

    pub fn is_empty(&self) -> bool {
        self.start >= self.end
    }

    pub fn range(&self) -> Range<usize> {
        self.start..self.end
    }
}

impl PointRange {
    /// `A..B`.
    pub fn new(start: usize, end: usize) -> PointRange {
        PointRange {
            start: RangeStart::At(start),
            end: Some(end),
        }
    }

    /// The chunk it selects of an execution of `len` points; a diagnostic when it does not fit.
    pub fn resolve(self, len: usize) -> Result<Chunk, ChunkError> {
        let start = match self.start {
            RangeStart::At(a) => a,
            RangeStart::FromEnd(n) => len
                .checked_sub(n)
                .ok_or(ChunkError::FewerPoints { last: n, len })?,
        };
        match self.end {
            Some(end) => Chunk::new(start, end, len),
            None if start > len => Err(ChunkError::StartPastEnd { start, len }),
            None => Chunk::new(start, len, len),
        }
    }
}

impl std::fmt::Display for PointRange {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.start {
            RangeStart::At(a) => write!(f, "{a}..")?,
            RangeStart::FromEnd(n) => write!(f, "-{n}..")?,
        }
        match self.end {
            Some(b) => write!(f, "{b}"),
            None => f.write_str("end"),
        }
    }
}

/// `A..B`, `A..end`, `A..` or `-N..end`, as the session's grammar reads a range (and `advise apply
/// --range` takes it); `None` when the text is not one.
impl std::str::FromStr for PointRange {
    type Err = ();

    fn from_str(s: &str) -> Result<PointRange, ()> {
        let (a, b) = s.trim().split_once("..").ok_or(())?;
        let whole = |t: &str| {
            (!t.is_empty() && t.bytes().all(|c| c.is_ascii_digit()))
                .then(|| t.parse::<usize>().ok())
                .flatten()
        };
        let start = match a.strip_prefix('-') {
            Some(n) => RangeStart::FromEnd(whole(n).ok_or(())?),
            None => RangeStart::At(whole(a).ok_or(())?),
        };
        let end = match b {
            "" | "end" => None,
            b => Some(whole(b).ok_or(())?),
        };
        Ok(PointRange { start, end })
    }
}

impl std::fmt::Display for Chunk {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}..{}", self.start, self.end)
    }
}

/// A chunk that does not fit its trace.
#[derive(Debug, Error, Diagnostic, Clone, PartialEq, Eq)]
pub enum ChunkError {
    #[error("the range {start}..{end} is reversed")]
    #[diagnostic(
        code(advise::chunk::reversed),
        help("write the smaller index first: {end}..{start}")
    )]
    Reversed { start: usize, end: usize },
    #[error("the range {start}..{end} is outside the execution, which has {len} points")]
    #[diagnostic(
        code(advise::chunk::out_of_range),
        help("ranges are half-open and 0-based: the whole execution is 0..{len}")
    )]
    OutOfRange {
        start: usize,
        end: usize,
        len: usize,
    },
    #[error("there are no last {last} points: the execution has {len}")]
    #[diagnostic(
        code(advise::chunk::fewer_points),
        help(
            "`-N..end` selects the last N points, N at most {len}; the whole execution is 0..end"
        )
    )]
    FewerPoints { last: usize, len: usize },
    #[error("point {start} is past the end of the execution, which has {len} points")]
    #[diagnostic(
        code(advise::chunk::start_past_end),
        help("`A..end` selects from point A to the end, A at most {len}")
    )]
    StartPastEnd { start: usize, len: usize },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_with_open_ends_resolve_against_the_execution() {
        let r = |s: &str| s.parse::<PointRange>().unwrap();
        assert_eq!(r("125..end").resolve(207), Chunk::new(125, 207, 207));
        assert_eq!(r("125..").resolve(207), Chunk::new(125, 207, 207));
        assert_eq!(r("-30..end").resolve(207), Chunk::new(177, 207, 207));
        assert_eq!(r("-30..200").resolve(207), Chunk::new(177, 200, 207));
        assert_eq!(
            r("-300..end").resolve(207),
            Err(ChunkError::FewerPoints {
                last: 300,
                len: 207
            })
        );
        assert_eq!(
            r("300..").resolve(207),
            Err(ChunkError::StartPastEnd {
                start: 300,
                len: 207
            })
        );
        for bad in ["", "..", "a..b", "1..-2", "--1..end", "1..ends", "+1..2"] {
            assert!(bad.parse::<PointRange>().is_err(), "{bad}");
        }
        for text in ["40..70", "125..end", "-30..end"] {
            assert_eq!(r(text).to_string(), text);
        }
    }

    #[test]
    fn chunks_are_validated() {
        assert!(Chunk::new(2, 5, 10).is_ok());
        assert_eq!(
            Chunk::new(5, 2, 10),
            Err(ChunkError::Reversed { start: 5, end: 2 })
        );
        assert!(matches!(
            Chunk::new(0, 11, 10),
            Err(ChunkError::OutOfRange { .. })
        ));
        assert!(Chunk::new(3, 3, 10).unwrap().is_empty());
    }

    #[test]
    fn a_reversed_chunk_built_by_hand_holds_no_points() {
        // The fields are public and deserialised: `Chunk::new` is not the only way in.
        let c: Chunk = serde_json::from_str(r#"{"start": 7, "end": 3}"#).unwrap();
        assert_eq!(c.len(), 0);
        assert!(c.is_empty());
        assert_eq!(c.range().count(), 0);
        assert_eq!(Chunk { start: 2, end: 5 }.len(), 3);
    }
}
