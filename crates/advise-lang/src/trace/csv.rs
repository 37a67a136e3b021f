//! CSV traces and demonstrations: a header naming `t`, the domain's observation and action
//! dimensions, optionally `x`, `y`, `theta` and an `episode` column; one row per control step.
//! Every malformed row or header becomes a [`TraceError`] at its line and field.

use super::{Episode, Pose, Trace, TraceError};
use crate::diag::{Loc, SourceMap, Src, did_you_mean, locate};
use crate::domain::Domain;
use crate::number::fmt_num;

impl Trace {
    /// The CSV header this trace writes: `t`, observation names, action names, then `x,y,theta`
    /// when poses are present.
    pub fn csv_header(&self, domain: &Domain) -> Vec<String> {
        let mut h = vec!["t".to_string()];
        h.extend(domain.observe.iter().map(|d| d.name.clone()));
        h.extend(domain.act.iter().map(|d| d.name.clone()));
        if self.pose.is_some() {
            h.extend(["x", "y", "theta"].map(String::from));
        }
        h
    }

    /// Write the trace as CSV with [`Trace::csv_header`].
    pub fn write_csv<W: std::io::Write>(&self, domain: &Domain, w: W) -> std::io::Result<()> {
        let mut out = csv::Writer::from_writer(w);
        out.write_record(self.csv_header(domain))?;
        let mut row: Vec<String> = Vec::new();
        for i in 0..self.len() {
            row.clear();
            row.push(fmt_num(self.t[i]));
            row.extend(self.z(i).iter().map(|v| fmt_num(*v)));
            row.extend(self.a(i).iter().map(|v| fmt_num(*v)));
            if let Some(p) = &self.pose {
                row.extend([p[i].x_m, p[i].y_m, p[i].theta_rad].map(fmt_num));
            }
            out.write_record(&row)?;
        }
        out.flush()
    }

    /// Parse a CSV trace. A file with an `episode` column must hold a single episode; use
    /// [`Episode::parse_csv`] for demonstration files with many.
    pub fn parse_csv(domain: &Domain, src: Src<'_>) -> Result<Trace, TraceError> {
        let mut eps = parse(domain, src, false)?;
        match eps.len() {
            0 => Ok(Trace::new(domain)),
            1 => Ok(eps.remove(0).trace),
            n => Err(TraceError::ManyEpisodes { count: n }),
        }
    }
}

impl Episode {
    /// Parse a CSV demonstrations file: consecutive rows with the same `episode` label form one
    /// episode (no column: one episode named after the file).
    pub fn parse_csv(domain: &Domain, src: Src<'_>) -> Result<Vec<Episode>, TraceError> {
        let episodes = parse(domain, src, true)?;
        if episodes.is_empty() {
            return Err(TraceError::NoDemonstrations {
                name: src.name.to_string(),
            });
        }
        Ok(episodes)
    }

    /// Read a CSV demonstrations file in a stream, for a file too large to hold whole: the same
    /// rows, rules and episodes as [`Episode::parse_csv`], at most `stream.max_points` rows, the
    /// bytes read reported as it goes. The text is never held: a refusal points at its line, read
    /// back from the file into `sources` as a source of its own (`FILE, line N`).
    pub fn stream_csv(
        domain: &Domain,
        sources: &mut SourceMap,
        path: &std::path::Path,
        stream: &mut Stream<'_>,
    ) -> Result<Vec<Episode>, TraceError> {
        let (file, _) = crate::files::open_regular(path, u64::MAX)?;
        let mut place = Streamed { sources, path };
        let input = std::io::BufReader::with_capacity(1 << 20, file);
        let episodes = parse_records(domain, input, true, &mut place, stream)?;
        if episodes.is_empty() {
            return Err(TraceError::NoDemonstrations {
                name: path.display().to_string(),
            });
        }
        Ok(episodes)
    }

    /// Write episodes as one CSV with an `episode` column first.
    pub fn write_csv<W: std::io::Write>(
        domain: &Domain,
        episodes: &[Episode],
        w: W,
    ) -> std::io::Result<()> {
        let mut out = csv::Writer::from_writer(w);
        let with_pose = episodes.iter().all(|e| e.trace.pose.is_some()) && !episodes.is_empty();
        let mut header = vec!["episode".to_string()];
        let mut h = episodes.first().map_or_else(
            || Trace::new(domain).csv_header(domain),
            |e| e.trace.csv_header(domain),
        );
        h.truncate(1 + domain.obs_dim() + domain.act_dim());
        header.extend(h);
        if with_pose {
            header.extend(["x", "y", "theta"].map(String::from));
        }
        out.write_record(&header)?;
        for e in episodes {
            let tr = &e.trace;
            for i in 0..tr.len() {
                let mut row = vec![e.name.clone(), fmt_num(tr.t[i])];
                row.extend(tr.z(i).iter().map(|v| fmt_num(*v)));
                row.extend(tr.a(i).iter().map(|v| fmt_num(*v)));
                if let (true, Some(p)) = (with_pose, &tr.pose) {
                    row.extend([p[i].x_m, p[i].y_m, p[i].theta_rad].map(fmt_num));
                }
                out.write_record(&row)?;
            }
        }
        out.flush()
    }
}

/// `demo`: the rows are demonstrations, whose actions must be within the domain's limits.
///
/// Over 150 lines because the header's column map (a local enum) and the row loop that reads
/// through it belong together; each refusal names its row and column.
fn parse(domain: &Domain, src: Src<'_>, demo: bool) -> Result<Vec<Episode>, TraceError> {
    let mut place = src;
    let mut stream = Stream {
        max_points: usize::MAX,
        progress: &mut |_| {},
    };
    parse_records(domain, src.text.as_bytes(), demo, &mut place, &mut stream)
}

/// Where a CSV's errors point: into its whole text (a [`Src`]), or, for a file read in a stream
/// ([`Episode::stream_csv`]), into the one line read back from the file.
pub(super) trait Place {
    /// The line starting at byte `byte` (its 1-based number `line`): field `col` of it, or the
    /// whole line.
    fn at(&mut self, byte: usize, line: u64, col: Option<usize>) -> Loc;
}

impl Place for Src<'_> {
    fn at(&mut self, byte: usize, _line: u64, col: Option<usize>) -> Loc {
        match col {
            Some(c) => Src::at(self, locate::csv_field(self.text, byte, c)),
            None => Src::at(self, locate::line_at(self.text, byte)),
        }
    }
}

/// The errors of a file read in a stream: the line read back from the file.
struct Streamed<'a> {
    sources: &'a mut SourceMap,
    path: &'a std::path::Path,
}

/// The longest part of a line a streamed file's diagnostic shows.
const SHOWN_LINE: u64 = 4096;

impl Place for Streamed<'_> {
    fn at(&mut self, byte: usize, line: u64, col: Option<usize>) -> Loc {
        use std::io::{Read, Seek, SeekFrom};
        let mut bytes = Vec::new();
        if let Ok(mut f) = std::fs::File::open(self.path)
            && f.seek(SeekFrom::Start(byte as u64)).is_ok()
        {
            let _ = f.take(SHOWN_LINE).read_to_end(&mut bytes);
        }
        let end = bytes
            .iter()
            .position(|b| *b == b'\n' || *b == b'\r')
            .unwrap_or(bytes.len());
        let text = String::from_utf8_lossy(&bytes[..end]).into_owned();
        let name = format!("{}, line {line}", self.path.display());
        let id = self.sources.add(name, text);
        let src = self.sources.src(id);
        match col {
            Some(c) => src.at(locate::csv_field(src.text, 0, c)),
            None => src.at(locate::line_at(src.text, 0)),
        }
    }
}

/// What a streamed read is held to and reports: at most `max_points` rows, and every
/// [`Stream::EVERY`] rows the bytes read so far.
pub struct Stream<'a> {
    pub max_points: usize,
    pub progress: &'a mut dyn FnMut(u64),
}

impl Stream<'_> {
    /// Rows between two progress reports.
    pub const EVERY: usize = 1 << 16;
}

/// The rows of a CSV read from `input`, errors placed by `place`.
///
/// Over 150 lines because the header's column map (a local enum) and the row loop that reads
/// through it belong together; each refusal names its row and column.
fn parse_records<R: std::io::Read>(
    domain: &Domain,
    input: R,
    demo: bool,
    place: &mut dyn Place,
    stream: &mut Stream<'_>,
) -> Result<Vec<Episode>, TraceError> {
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .trim(csv::Trim::All)
        .flexible(true)
        .from_reader(input);
    let mut records = rdr.records();
    let header = match records.next() {
        None => return Err(TraceError::Empty),
        Some(r) => r.map_err(|e| TraceError::Csv {
            message: e.to_string(),
        })?,
    };
    let header_byte = header.position().map_or(0, |p| p.byte() as usize);
    let header_line = header.position().map_or(1, |p| p.line());

    // Map each column to its slot: t, z[i], a[j], pose[k].
    #[derive(Clone, Copy)]
    enum Slot {
        Episode,
        T,
        Z(usize),
        A(usize),
        Pose(usize),
    }
    let mut slots = Vec::with_capacity(header.len());
    let mut seen: Vec<&str> = Vec::new();
    for (col, h) in header.iter().enumerate() {
        if seen.contains(&h) {
            return Err(TraceError::DuplicateColumn {
                column: h.to_string(),
                at: place.at(header_byte, header_line, Some(col)),
            });
        }
        seen.push(h);
        let slot = if h == "t" {
            Slot::T
        } else if h == "episode" {
            Slot::Episode
        } else if let Some(i) = domain.index_of(crate::domain::Space::Observation, h) {
            Slot::Z(i)
        } else if let Some(i) = domain.index_of(crate::domain::Space::Action, h) {
            Slot::A(i)
        } else if let Some(k) = ["x", "y", "theta"].iter().position(|p| *p == h) {
            Slot::Pose(k)
        } else {
            let known = known_columns(domain);
            let help = did_you_mean(h, &known)
                .unwrap_or_else(|| format!("the known columns are: {}", known.join(", ")));
            return Err(TraceError::UnknownColumn {
                column: h.to_string(),
                help,
                at: place.at(header_byte, header_line, Some(col)),
                domain: domain.name.clone(),
            });
        };
        slots.push(slot);
    }
    let required = std::iter::once("t".to_string())
        .chain(domain.observe.iter().map(|d| d.name.clone()))
        .chain(domain.act.iter().map(|d| d.name.clone()));
    for r in required {
        if !seen.contains(&r.as_str()) {
            return Err(TraceError::MissingColumn {
                column: r,
                domain: domain.name.clone(),
                expected: known_columns(domain)[..1 + domain.obs_dim() + domain.act_dim()]
                    .join(","),
                at: place.at(header_byte, header_line, None),
            });
        }
    }
    let pose_cols = seen
        .iter()
        .filter(|h| ["x", "y", "theta"].contains(h))
        .count();
    if pose_cols != 0 && pose_cols != 3 {
        let missing = ["x", "y", "theta"]
            .into_iter()
            .find(|p| !seen.contains(p))
            .unwrap_or("x");
        return Err(TraceError::MissingColumn {
            column: missing.into(),
            domain: domain.name.clone(),
            expected: "x,y,theta (all three, or none)".into(),
            at: place.at(header_byte, header_line, None),
        });
    }

    let mut episodes: Vec<Episode> = Vec::new();
    // Each episode's label and first line: an episode's rows are contiguous.
    let mut starts: std::collections::HashMap<String, u64> = Default::default();
    let (mut z, mut a) = (vec![0.0; domain.obs_dim()], vec![0.0; domain.act_dim()]);
    let mut pose = [0.0; 3];
    let mut points = 0usize;
    for rec in records {
        let rec = rec.map_err(|e| TraceError::Csv {
            message: e.to_string(),
        })?;
        let byte = rec.position().map_or(0, |p| p.byte() as usize);
        let line = rec.position().map_or(0, |p| p.line());
        if rec.len() == 1 && rec.get(0) == Some("") {
            continue; // blank line
        }
        points += 1;
        if points > stream.max_points {
            return Err(TraceError::TooManyPoints {
                line,
                max: stream.max_points,
            });
        }
        if points.is_multiple_of(Stream::EVERY) {
            (stream.progress)(byte as u64);
        }
        if rec.len() != slots.len() {
            return Err(TraceError::RowLength {
                line,
                found: rec.len(),
                expected: slots.len(),
                at: place.at(byte, line, None),
            });
        }
        let mut t = 0.0;
        let mut label = "";
        for (col, (field, slot)) in rec.iter().zip(&slots).enumerate() {
            if let Slot::Episode = slot {
                label = field;
                continue;
            }
            let column = || header.get(col).unwrap_or("?").to_string();
            let v: f64 = field.parse().map_err(|_| TraceError::NotANumber {
                line,
                column: column(),
                value: field.to_string(),
                at: place.at(byte, line, Some(col)),
            })?;
            if !v.is_finite() {
                return Err(TraceError::NotFinite {
                    line,
                    column: column(),
                    value: field.to_string(),
                    at: place.at(byte, line, Some(col)),
                });
            }
            // The demonstration rule ([`super::demo_value_fault`]); finiteness is refused above
            // for every column, demonstrations or not.
            if let (true, Slot::A(i)) = (demo, *slot)
                && let Some(super::ValueFault::OutsideLimits(l)) =
                    super::demo_value_fault(domain, crate::domain::Space::Action, i, v)
            {
                return Err(TraceError::ActionOutOfLimits {
                    line,
                    column: column(),
                    value: field.to_string(),
                    lo: fmt_num(l.lo),
                    hi: fmt_num(l.hi),
                    at: place.at(byte, line, Some(col)),
                });
            }
            match *slot {
                Slot::Episode => {}
                Slot::T => t = v,
                Slot::Z(i) => z[i] = v,
                Slot::A(i) => a[i] = v,
                Slot::Pose(k) => pose[k] = v,
            }
        }
        if episodes.last().is_none_or(|e| e.name != label) {
            if let Some(&first_line) = starts.get(label) {
                let col = slots
                    .iter()
                    .position(|s| matches!(s, Slot::Episode))
                    .unwrap_or(0);
                return Err(TraceError::EpisodeSplit {
                    line,
                    first_line,
                    episode: label.to_string(),
                    at: place.at(byte, line, Some(col)),
                });
            }
            starts.insert(label.to_string(), line);
            episodes.push(Episode {
                name: label.to_string(),
                trace: Trace::new(domain),
            });
        }
        let Some(Episode { trace, .. }) = episodes.last_mut() else {
            unreachable!("an episode was pushed above")
        };
        if let Some(&prev) = trace.t.last()
            && t <= prev
        {
            let tcol = slots.iter().position(|s| matches!(s, Slot::T)).unwrap_or(0);
            let at = place.at(byte, line, Some(tcol));
            return Err(if t == prev {
                TraceError::TimeRepeated { line, t, at }
            } else {
                TraceError::TimeBackwards { line, t, prev, at }
            });
        }
        let p = (pose_cols == 3).then(|| Pose::new(pose[0], pose[1], pose[2]));
        trace.push(t, &z, &a, p);
    }
    Ok(episodes)
}

fn known_columns(domain: &Domain) -> Vec<String> {
    std::iter::once("t".to_string())
        .chain(domain.observe.iter().map(|d| d.name.clone()))
        .chain(domain.act.iter().map(|d| d.name.clone()))
        .chain(["x", "y", "theta", "episode"].map(String::from))
        .collect()
}

#[cfg(test)]
mod stream_tests {
    use super::*;
    use crate::diag::render::render;

    const CSV: &str = "episode,t,dist2,bearing,dheading,trans,rot\n\
        a,0,4,0.5,0.1,0.2,0.1\n\
        a,0.1,3.9,0.5,0.1,0.2,0.1\n\
        \n\
        b,0,1,-0.5,0,0.1,-0.2\n\
        b,0.1,0.9,-0.4,0,0.1,-0.2\n\
        b,0.2,0.8,-0.3,0,0.1,-0.2\n";

    fn write(text: &str) -> tempfile::NamedTempFile {
        let mut f = tempfile::NamedTempFile::new().unwrap();
        std::io::Write::write_all(&mut f, text.as_bytes()).unwrap();
        f
    }

    fn stream(
        text: &str,
        max_points: usize,
    ) -> (Result<Vec<Episode>, TraceError>, SourceMap, Vec<u64>) {
        let f = write(text);
        let mut sources = SourceMap::new();
        let mut reports = Vec::new();
        let mut report = |b| reports.push(b);
        let mut s = Stream {
            max_points,
            progress: &mut report,
        };
        let r = Episode::stream_csv(&Domain::positioning(), &mut sources, f.path(), &mut s);
        (r, sources, reports)
    }

    /// A streamed file gives the episodes the whole-text parser gives, to the bit.
    #[test]
    fn a_streamed_file_reads_as_the_whole_text_does() {
        let mut sources = SourceMap::new();
        let id = sources.add("x.csv", CSV);
        let whole = Episode::parse_csv(&Domain::positioning(), sources.src(id)).unwrap();
        let (streamed, _, _) = stream(CSV, 100);
        assert_eq!(streamed.unwrap(), whole);
    }

    /// A refusal in a streamed file names its line and shows that line, read back from the file;
    /// more rows than the bound are refused at the first one over it.
    #[test]
    fn a_streamed_refusal_shows_its_line_and_the_points_are_bounded() {
        let bad = CSV.replace("0.9,-0.4", "0.9,oops");
        let (r, sources, _) = stream(&bad, 100);
        let e = r.unwrap_err();
        let shown = render(&sources, &e, false);
        assert!(
            shown.contains("line 6, column `bearing`: `oops` is not a number"),
            "{shown}"
        );
        assert!(shown.contains("b,0.1,0.9,oops,0,0.1,-0.2"), "{shown}");
        assert!(shown.contains(", line 6"), "{shown}");
        let (r, _, _) = stream(CSV, 4);
        let e = r.unwrap_err();
        assert_eq!(
            e.to_string(),
            "line 7: the demonstrations hold more than 4 points"
        );
        assert_eq!(
            miette::Diagnostic::code(&e).unwrap().to_string(),
            "advise::trace::too_many_points"
        );
    }
}
