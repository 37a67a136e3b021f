//! CSV traces and demonstrations: a header naming `t`, the domain's observation and action
//! dimensions, optionally `x`, `y`, `theta` and an `episode` column; one row per control step.
//! Every malformed row or header becomes a [`TraceError`] at its line and field.

use super::{Episode, Pose, Trace, TraceError};
use crate::diag::{Src, did_you_mean, locate};
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
    let text = src.text;
    let field_at = |byte: usize, col: usize| src.at(locate::csv_field(text, byte, col));
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .trim(csv::Trim::All)
        .flexible(true)
        .from_reader(text.as_bytes());
    let mut records = rdr.records();
    let header = match records.next() {
        None => return Err(TraceError::Empty),
        Some(r) => r.map_err(|e| TraceError::Csv {
            message: e.to_string(),
        })?,
    };
    let header_byte = header.position().map_or(0, |p| p.byte() as usize);
    let header_span = src.at(locate::line_at(text, header_byte));

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
                at: field_at(header_byte, col),
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
                at: field_at(header_byte, col),
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
                at: header_span,
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
            at: header_span,
        });
    }

    let mut episodes: Vec<Episode> = Vec::new();
    // Each episode's label and first line: an episode's rows are contiguous.
    let mut starts: std::collections::HashMap<String, u64> = Default::default();
    let (mut z, mut a) = (vec![0.0; domain.obs_dim()], vec![0.0; domain.act_dim()]);
    let mut pose = [0.0; 3];
    for rec in records {
        let rec = rec.map_err(|e| TraceError::Csv {
            message: e.to_string(),
        })?;
        let byte = rec.position().map_or(0, |p| p.byte() as usize);
        let line = rec.position().map_or(0, |p| p.line());
        if rec.len() == 1 && rec.get(0) == Some("") {
            continue; // blank line
        }
        if rec.len() != slots.len() {
            return Err(TraceError::RowLength {
                line,
                found: rec.len(),
                expected: slots.len(),
                at: src.at(locate::line_at(text, byte)),
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
                at: field_at(byte, col),
            })?;
            if !v.is_finite() {
                return Err(TraceError::NotFinite {
                    line,
                    column: column(),
                    value: field.to_string(),
                    at: field_at(byte, col),
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
                    at: field_at(byte, col),
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
                    at: field_at(byte, col),
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
            let at = field_at(byte, tcol);
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
