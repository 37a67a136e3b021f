//! A dataset's files: saving (JSON record or CSV points, atomically), loading and validating a
//! saved dataset whole, demonstrations files, and the advice export.

use super::*;

impl Dataset {
    /// Save the dataset atomically ([`advise_lang::files::write_atomic`]): `.json` is the full record
    /// (what `open` reads back), `.csv` the points alone; any other extension is refused, as the
    /// file would not be what its name says. Returns what was written.
    pub fn save(&self, path: &Path) -> Result<SavedFormat, DatasetError> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        let format = match ext.as_deref() {
            Some("json") => SavedFormat::Json,
            Some("csv") => SavedFormat::Csv,
            _ => {
                return Err(DatasetError::UnknownFormat {
                    path: path.display().to_string(),
                    stem: path.with_extension("").display().to_string(),
                });
            }
        };
        advise_lang::files::write_atomic(path, |w| match format {
            SavedFormat::Json => serde_json::to_writer(w, &self.to_file()).map_err(Into::into),
            SavedFormat::Csv => self.write_csv(w),
        })?;
        Ok(format)
    }

    /// Points only, for other tools: `provenance`, observation and action columns, `m`.
    pub fn write_csv<W: std::io::Write>(&self, w: W) -> std::io::Result<()> {
        self.write_csv_filtered(w, |_| true)
    }

    /// Advised points only, with their provenance: operator, parameters, chunk, execution.
    pub fn write_advice_csv<W: std::io::Write>(&self, w: W) -> std::io::Result<usize> {
        let mut n = 0;
        self.write_csv_filtered(w, |p| {
            let keep = matches!(p, Provenance::Advice { .. });
            n += keep as usize;
            keep
        })?;
        Ok(n)
    }

    fn write_csv_filtered<W: std::io::Write>(
        &self,
        w: W,
        mut keep: impl FnMut(&Provenance) -> bool,
    ) -> std::io::Result<()> {
        let mut out = csv::Writer::from_writer(w);
        let mut header = vec!["source".to_string(), "detail".to_string()];
        header.extend(self.domain.observe.iter().map(|d| d.name.clone()));
        header.extend(self.domain.act.iter().map(|d| d.name.clone()));
        header.push("m".into());
        out.write_record(&header)?;
        for i in 0..self.len() {
            let p = self.provenance(i);
            if !keep(&p) {
                continue;
            }
            let (source, detail) = match p {
                Provenance::Demonstration { demo, index } => {
                    let name = self
                        .demos
                        .iter()
                        .find(|d| d.id == demo)
                        .map_or("?", |d| d.name.as_str());
                    (format!("demo {demo}"), format!("{name} point {index}"))
                }
                Provenance::Advice {
                    advice,
                    index,
                    source,
                } => {
                    let detail = self.advice.iter().find(|r| r.id == advice).map_or_else(
                        || "?".to_string(),
                        |r| {
                            format!(
                                "{} on {} of execution {}, point {source} (synthesized {index})",
                                r.applied.invocation(),
                                r.applied.chunk,
                                self.execution_number(r.execution).unwrap_or(usize::MAX)
                            )
                        },
                    );
                    (format!("advice {advice}"), detail)
                }
            };
            let mut row = vec![source, detail];
            row.extend(self.z(i).iter().map(|v| fmt_num(*v)));
            row.extend(self.a(i).iter().map(|v| fmt_num(*v)));
            row.push(fmt_num(self.m(i)));
            out.write_record(&row)?;
        }
        out.flush()
    }

    fn to_file(&self) -> DatasetFile {
        DatasetFile {
            format: "advise-dataset-1".into(),
            domain: self.domain.clone(),
            points: (0..self.len())
                .map(|i| FilePoint {
                    z: self.z(i).to_vec(),
                    a: self.a(i).to_vec(),
                    m: self.m(i),
                    provenance: self.provenance(i),
                })
                .collect(),
            demos: self.demos.clone(),
            executions: self.executions.clone(),
            advice: self.advice.clone(),
            critiques: self.critiques.clone(),
            next_id: self.next_id,
        }
    }

    /// The dataset as the JSON text `save` writes.
    pub fn to_json_string(&self) -> String {
        serde_json::to_string(&self.to_file())
            .expect("a dataset's values are finite and its keys strings")
    }

    /// Load a dataset saved as JSON, read into `sources` and validated whole
    /// ([`Dataset::parse`]).
    pub fn load(sources: &mut SourceMap, path: &Path) -> Result<Dataset, DatasetError> {
        advise_lang::files::parse_file(sources, path, Dataset::parse)
    }

    /// [`Dataset::parse`] of a text outside any session (its error brings its own source map).
    pub fn from_json_str(name: &str, text: &str) -> Result<Dataset, Sourced<DatasetError>> {
        let mut sources = SourceMap::new();
        let id = sources.add(name, text);
        Dataset::parse(sources.src(id)).map_err(|e| sources.attach(e))
    }

    /// Whether JSON text is a saved dataset (rather than a trace or demonstrations): its top
    /// level has the `format` key. Malformed JSON counts as a dataset when it names the dataset
    /// format (`"advise-dataset-`), so that its error is the dataset's.
    pub fn is_dataset_json(text: &str) -> bool {
        #[derive(Deserialize)]
        struct Probe {
            format: Option<serde::de::IgnoredAny>,
        }
        match serde_json::from_str::<Probe>(text) {
            Ok(p) => p.format.is_some(),
            Err(_) => text.contains("\"advise-dataset-"),
        }
    }

    /// Parse and validate a saved dataset; the first problem found is the error. A dataset that
    /// loads is one the session could have built: every id unique and below `next_id`, every
    /// reference resolved, every point of the domain's shape and finite, every action within its
    /// limits, and
    /// the weights what the critiques say.
    pub fn parse(src: Src<'_>) -> Result<Dataset, DatasetError> {
        let text = src.text;
        let file: DatasetFile = serde_json::from_str(text).map_err(|e| {
            let span = locate::line_col(text, e.line(), e.column());
            let message = e.to_string();
            // NaN and infinity were saved as `null` by earlier versions.
            if message.starts_with("invalid type: null, expected f64") {
                // serde points after the value; cover the `null` itself.
                let end = span.start;
                let start = text[..end].rfind("null").filter(|s| s + 4 >= end);
                let span = start.map_or(span, |s| s..s + 4);
                DatasetError::Null { at: src.at(span) }
            } else {
                DatasetError::Json {
                    message,
                    at: src.at(span),
                }
            }
        })?;
        if file.format != "advise-dataset-1" {
            return Err(DatasetError::Inconsistent {
                what: format!("unknown format `{}`", file.format),
            });
        }
        validate(&file)?;
        let mut d = Dataset::new(&file.domain);
        d.reserve(file.points.len());
        for p in &file.points {
            d.push_point(&p.z, &p.a, p.provenance);
        }
        d.demos = file.demos;
        d.executions = file.executions;
        d.advice = file.advice;
        d.critiques = file.critiques;
        d.next_id = file.next_id;
        // The stored weights must be what the critique records say.
        d.recompute_weights();
        if file.points.iter().enumerate().any(|(i, p)| p.m != d.m(i)) {
            return Err(DatasetError::Inconsistent {
                what: "the weights do not match the critique records".into(),
            });
        }
        // The directional increments, which `m` does not hold, must not sum to infinity either.
        d.check_weights()?;
        Ok(d)
    }

    /// The training data as demonstrations: each demonstration, and each piece of advice's
    /// points, becomes one episode named after where it came from (`NAME demo 3 (teacher-0)`,
    /// `NAME advice 7 (slow_down on 40..70)`). Critique weights are not carried (a
    /// demonstration's points weigh 1); executions are not training data and are left out. Point
    /// times are a demonstration's recorded times, an advice's those of the execution points it
    /// was synthesized from, from 0; the points' numbers where the dataset has none (a file
    /// written before datasets kept times), which [`DemoTimes::of`] reads as none.
    pub fn to_episodes(&self, name: &str) -> Vec<Episode> {
        let mut order: Vec<(Provenance, Vec<usize>)> = Vec::new();
        let mut slot: HashMap<(bool, u32), usize> = HashMap::new();
        for i in 0..self.len() {
            let key = match self.provenance(i) {
                Provenance::Demonstration { demo, .. } => (true, demo),
                Provenance::Advice { advice, .. } => (false, advice),
            };
            let k = *slot.entry(key).or_insert_with(|| {
                order.push((self.provenance(i), Vec::new()));
                order.len() - 1
            });
            order[k].1.push(i);
        }
        order
            .into_iter()
            .map(|(p, points)| {
                let label = match p {
                    Provenance::Demonstration { demo, .. } => {
                        let d = self.demos.iter().find(|d| d.id == demo);
                        format!(
                            "{name} demo {demo} ({})",
                            d.map_or("?", |d| d.name.as_str())
                        )
                    }
                    Provenance::Advice { advice, .. } => {
                        let r = self.advice.iter().find(|r| r.id == advice);
                        format!(
                            "{name} advice {advice} ({})",
                            r.map_or_else(
                                || "?".to_string(),
                                |r| format!("{} on {}", r.applied.invocation(), r.applied.chunk)
                            )
                        )
                    }
                };
                let times = self.episode_times(p, &points);
                let mut trace = Trace::new(&self.domain);
                for (k, &i) in points.iter().enumerate() {
                    trace.push(times[k], self.z(i), self.a(i), None);
                }
                Episode { name: label, trace }
            })
            .collect()
    }
}

impl Dataset {
    /// The times, from 0, of the points `points` (in order) of the demonstration or advice that
    /// `p` names: see [`Dataset::to_episodes`].
    fn episode_times(&self, p: Provenance, points: &[usize]) -> Vec<f64> {
        match p {
            Provenance::Demonstration { demo, .. } => {
                let times = self
                    .demos
                    .iter()
                    .find(|d| d.id == demo)
                    .and_then(|d| d.times());
                points
                    .iter()
                    .enumerate()
                    .map(|(k, &i)| match (self.provenance(i), &times) {
                        (Provenance::Demonstration { index, .. }, Some(t)) => {
                            t.time_s(index as usize)
                        }
                        _ => k as f64,
                    })
                    .collect()
            }
            Provenance::Advice { advice, .. } => {
                let exec = self
                    .advice
                    .iter()
                    .find(|r| r.id == advice)
                    .and_then(|r| self.executions.iter().find(|e| e.id == r.execution));
                let at = |i: usize| match (self.provenance(i), exec) {
                    (Provenance::Advice { source, .. }, Some(e)) => {
                        e.points.get(source as usize).map(|p| p.t)
                    }
                    _ => None,
                };
                let t: Option<Vec<f64>> = points.iter().map(|&i| at(i)).collect();
                match t {
                    Some(t) if t.iter().all(|v| v.is_finite()) => {
                        let first = t.first().copied().unwrap_or(0.0);
                        t.iter().map(|v| v - first).collect()
                    }
                    _ => (0..points.len()).map(|k| k as f64).collect(),
                }
            }
        }
    }
}

/// Demonstrations read from a file, and whether the file was a saved dataset.
#[derive(Clone, Debug)]
pub struct Demonstrations {
    pub episodes: Vec<Episode>,
    /// For a saved dataset: how many of the episodes were its demonstrations and how many its
    /// advice.
    pub from_dataset: Option<(usize, usize)>,
}

/// Read demonstrations for `domain` from any file that holds them: a demonstrations file (CSV
/// or JSON, [`Episode`]) or a dataset saved by a session ([`Dataset::to_episodes`]).
pub fn load_demonstrations(
    sources: &mut SourceMap,
    domain: &Domain,
    path: &Path,
) -> Result<Demonstrations, DatasetError> {
    load_demonstrations_with(sources, domain, path, &mut |_, _| {})
}

/// A CSV demonstrations file larger than this is read in a stream ([`Episode::stream_csv`]),
/// never held whole: up to [`MAX_STREAM_POINTS`] points, whatever its length in bytes. Smaller
/// ones (and JSON, which is held whole) are read as before, under the whole-text cap.
pub const STREAM_CSV_BYTES: u64 = 64 << 20;

/// The most points a streamed demonstrations file may hold: 50 million, some 10 GB once a
/// learner holds them with both indexes, more than a 24 GB machine wants to give one session.
pub const MAX_STREAM_POINTS: usize = 50_000_000;

/// [`load_demonstrations`], reporting `progress(bytes read, bytes in all)` while it streams a
/// large CSV file (nothing for a file read whole).
pub fn load_demonstrations_with(
    sources: &mut SourceMap,
    domain: &Domain,
    path: &Path,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<Demonstrations, DatasetError> {
    let size = std::fs::metadata(path).map_or(0, |m| m.len());
    if !advise_lang::trace::is_json(path) && size > STREAM_CSV_BYTES {
        let mut report = |bytes| progress(bytes, size);
        let mut stream = advise_lang::trace::csv::Stream {
            max_points: MAX_STREAM_POINTS,
            progress: &mut report,
        };
        let episodes = Episode::stream_csv(domain, sources, path, &mut stream)?;
        progress(size, size);
        return Ok(Demonstrations {
            episodes,
            from_dataset: None,
        });
    }
    advise_lang::files::parse_file(sources, path, |src| {
        let name = path.display().to_string();
        let is_json = advise_lang::trace::is_json(path);
        if is_json && Dataset::is_dataset_json(src.text) {
            let ds = Dataset::parse(src)?;
            if ds.domain() != domain {
                return Err(advise_lang::trace::TraceError::DomainMismatch {
                    expected: domain.name.clone(),
                    found: ds.domain().name.clone(),
                }
                .into());
            }
            let from = (ds.demos().len(), ds.advice().len());
            return Ok(Demonstrations {
                episodes: ds.to_episodes(&name),
                from_dataset: Some(from),
            });
        }
        if !is_json && src.text.starts_with("source,detail,") {
            return saved_csv(domain, src);
        }
        let episodes = if is_json {
            Episode::parse_json(domain, src)?
        } else {
            Episode::parse_csv(domain, src)?
        };
        Ok(Demonstrations {
            episodes,
            from_dataset: None,
        })
    })
}

/// A dataset saved as CSV ([`Dataset::write_csv`]: `source,detail`, the observations, the
/// actions, `m`) read back as demonstrations, as a saved JSON dataset is
/// ([`Dataset::to_episodes`]): each source (`demo 3`, `advice 7`) one episode of its rows in file
/// order, at times 0, 1, 2... s, named `FILE demo 3`; the critique weight `m` is not carried.
/// Every value is checked as a dataset's are ([`check_point`]); a source's rows are contiguous.
fn saved_csv(
    domain: &Domain,
    src: advise_lang::diag::Src<'_>,
) -> Result<Demonstrations, DatasetError> {
    let mut columns = vec!["source".to_string(), "detail".to_string()];
    columns.extend(domain.observe.iter().map(|d| d.name.clone()));
    columns.extend(domain.act.iter().map(|d| d.name.clone()));
    columns.push("m".into());
    let record = |at: String, what: String| DatasetError::Record { at, what };
    let mut rows = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_reader(src.text.as_bytes());
    let header: Vec<String> = rows
        .headers()
        .map_err(|e| record(format!("{} line 1", src.name), e.to_string()))?
        .iter()
        .map(String::from)
        .collect();
    if header != columns {
        return Err(DatasetError::Dimension {
            at: format!("{} line 1", src.name),
            what: format!(
                "its columns are {}; a `{}` dataset saved as CSV has {}",
                header.join(","),
                domain.name,
                columns.join(",")
            ),
            expected: expected(domain),
        });
    }
    let (od, ad) = (domain.obs_dim(), domain.act_dim());
    let mut episodes: Vec<Episode> = Vec::new();
    let mut seen: HashMap<String, u64> = HashMap::new();
    // The source of the episode being read.
    let mut current = String::new();
    let (mut z, mut a) = (vec![0.0; od], vec![0.0; ad]);
    for row in rows.records() {
        let row = row.map_err(|e| record(src.name.to_string(), e.to_string()))?;
        let line = row.position().map_or(0, |p| p.line());
        let at = |c: usize| format!("{}:{line} column {}", src.name, columns[c]);
        if row.len() != columns.len() {
            return Err(record(
                format!("{} line {line}", src.name),
                format!("{} fields; the header has {}", row.len(), columns.len()),
            ));
        }
        for c in 2..2 + od + ad {
            let v: f64 = row[c]
                .parse()
                .map_err(|_| record(at(c), format!("`{}` is not a number", &row[c])))?;
            if c < 2 + od {
                z[c - 2] = v;
            } else {
                a[c - 2 - od] = v;
            }
        }
        check_point(domain, &z, &a, |space, k| {
            at(2 + k + if space == "a" { od } else { 0 })
        })?;
        let source = &row[0];
        if episodes.is_empty() || source != current {
            if let Some(first) = seen.get(source) {
                return Err(record(
                    at(0),
                    format!(
                        "`{source}` starts again here (it began on line {first}); a source's rows are contiguous, as `save` writes them"
                    ),
                ));
            }
            seen.insert(source.to_string(), line);
            current = source.to_string();
            episodes.push(Episode {
                name: format!("{} {source}", src.name),
                trace: Trace::new(domain),
            });
        }
        if let Some(e) = episodes.last_mut() {
            // A saved CSV dataset keeps no times: the points' numbers say so (`DemoTimes::of`).
            e.trace.push(e.trace.len() as f64, &z, &a, None);
        }
    }
    if episodes.is_empty() {
        return Err(record(
            src.name.to_string(),
            "a saved dataset with no points holds no demonstrations".into(),
        ));
    }
    let demos = seen.keys().filter(|k| k.starts_with("demo ")).count();
    Ok(Demonstrations {
        from_dataset: Some((demos, episodes.len() - demos)),
        episodes,
    })
}

/// What [`Dataset::save`] wrote.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SavedFormat {
    /// The full record, which `open` reads back.
    Json,
    /// The points alone, for other tools.
    Csv,
}

impl SavedFormat {
    /// In words, for the session's reply.
    pub fn describe(self) -> &'static str {
        match self {
            SavedFormat::Json => "JSON, with provenance; `open` reads it back",
            SavedFormat::Csv => "CSV, points only; `load demos` reads it back, `open` cannot",
        }
    }
}

/// Every check of a dataset file but the weights, in file order; the first problem is returned.
fn validate(file: &DatasetFile) -> Result<(), DatasetError> {
    let domain = &file.domain;
    if domain.observe.is_empty() || domain.act.is_empty() {
        return Err(DatasetError::Dimension {
            at: "domain".into(),
            what: "the domain needs at least one observation and one action dimension".into(),
            expected: expected(domain),
        });
    }
    validate_ids(file)?;
    validate_executions(file)?;
    let executions: HashMap<u32, &ExecutionRecord> =
        file.executions.iter().map(|e| (e.id, e)).collect();
    let exec_len = |at: String, id: u32| -> Result<usize, DatasetError> {
        executions
            .get(&id)
            .map(|e| e.points.len())
            .ok_or(DatasetError::Dangling {
                at,
                what: "execution",
                id,
            })
    };
    let mut advice_points: HashMap<u32, u32> = HashMap::new();
    for (i, r) in file.advice.iter().enumerate() {
        let len = exec_len(format!("advice[{i}].execution"), r.execution)?;
        check_advice(
            domain,
            &r.applied,
            r.execution,
            len,
            &format!("advice[{i}]"),
        )?;
        advice_points.insert(r.id, 0);
    }
    for (i, rec) in file.critiques.iter().enumerate() {
        let len = exec_len(format!("critiques[{i}].execution"), rec.execution)?;
        validate_critique(domain, i, rec, len)?;
    }
    for (i, d) in file.demos.iter().enumerate() {
        if let Some(link) = &d.takeover {
            let at = || format!("demos[{i}].takeover");
            let len = exec_len(format!("{}.execution", at()), link.execution)?;
            check_takeover(link, len, d.points as usize, at)?;
        }
    }
    validate_points(file, advice_points)
}

/// The domain's dimensions by name, for a message about a point's shape.
fn expected(domain: &Domain) -> String {
    let names = |dims: &[advise_lang::domain::Dim]| {
        dims.iter()
            .map(|d| d.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    format!(
        "observation [{}], action [{}]",
        names(&domain.observe),
        names(&domain.act)
    )
}

fn finite(at: String, v: f64) -> Result<(), DatasetError> {
    check_finite_value(v, || at.clone())
}

/// One sequence of ids for every kind of record, and a `next_id` beyond them that can grow.
fn validate_ids(file: &DatasetFile) -> Result<(), DatasetError> {
    let mut owner: HashMap<u32, String> = HashMap::new();
    let mut max_id = 0;
    let records = file
        .demos
        .iter()
        .enumerate()
        .map(|(i, r)| (r.id, format!("demos[{i}]")))
        .chain(
            file.executions
                .iter()
                .enumerate()
                .map(|(i, r)| (r.id, format!("executions[{i}]"))),
        )
        .chain(
            file.advice
                .iter()
                .enumerate()
                .map(|(i, r)| (r.id, format!("advice[{i}]"))),
        )
        .chain(
            file.critiques
                .iter()
                .enumerate()
                .map(|(i, r)| (r.id, format!("critiques[{i}]"))),
        );
    for (id, at) in records {
        if let Some(first) = owner.get(&id) {
            return Err(DatasetError::DuplicateId {
                id,
                first: first.clone(),
                second: at,
            });
        }
        max_id = max_id.max(id);
        owner.insert(id, at);
    }
    if file.next_id < max_id {
        return Err(DatasetError::NextId {
            next_id: file.next_id,
            max_id,
        });
    }
    // An id space that cannot grow is refused now, not at the first advice.
    next_id_after(file.next_id)?;
    Ok(())
}

/// The executions' points: each of the domain's shape, finite, and all with a `pose` or none.
fn validate_executions(file: &DatasetFile) -> Result<(), DatasetError> {
    let domain = &file.domain;
    for (i, e) in file.executions.iter().enumerate() {
        for &v in e.goal.iter().flatten() {
            finite(format!("executions[{i}].goal"), v)?;
        }
        for (j, p) in e.points.iter().enumerate() {
            let at = format!("executions[{i}].points[{j}]");
            // Executions are what the base recorded; they are checked for shape, not limits
            // (an observation beyond a limit is a fact of the run).
            for (space, vals, n) in [("z", &p.z, domain.obs_dim()), ("a", &p.a, domain.act_dim())] {
                if vals.len() != n {
                    return Err(DatasetError::Dimension {
                        at: format!("{at}.{space}"),
                        what: format!("{} values where the domain has {n}", vals.len()),
                        expected: expected(domain),
                    });
                }
            }
            let all = std::iter::once(p.t)
                .chain(p.z.iter().copied())
                .chain(p.a.iter().copied())
                .chain(p.pose.into_iter().flatten());
            for v in all {
                finite(at.clone(), v)?;
            }
            if (p.pose.is_some()) != e.points[0].pose.is_some() {
                return Err(DatasetError::Record {
                    at,
                    what: "some points of the execution have a `pose` and others do not".into(),
                });
            }
        }
    }
    Ok(())
}

/// Critique `i` of the file, of an execution of `len` points.
fn validate_critique(
    domain: &Domain,
    i: usize,
    rec: &CritiqueRecord,
    len: usize,
) -> Result<(), DatasetError> {
    let c = &rec.critique;
    check_chunk(c.chunk, rec.execution, len, || {
        format!("critiques[{i}].chunk")
    })?;
    finite(format!("critiques[{i}].kappa"), c.kappa)?;
    for (k, (_, inc)) in c.increments.iter().enumerate() {
        finite(format!("critiques[{i}].increments[{k}]"), *inc)?;
    }
    let negative = c.increments.iter().position(|(_, inc)| *inc < 0.0);
    if let (true, Some(k)) = (c.directional, negative) {
        // The BC search is exact only while no weight falls below 1 (the isotropic weights
        // are checked point by point below).
        return Err(DatasetError::Record {
            at: format!("critiques[{i}].increments[{k}]"),
            what: "a directional critique's increment is never negative".into(),
        });
    }
    if c.directional && c.flagged.len() != c.increments.len() {
        return Err(DatasetError::Record {
            at: format!("critiques[{i}].flagged"),
            what: format!(
                "a directional critique keeps one flagged observation per increment: {} increments, {} observations",
                c.increments.len(),
                c.flagged.len()
            ),
        });
    }
    if !c.directional && !c.flagged.is_empty() {
        return Err(DatasetError::Record {
            at: format!("critiques[{i}].flagged"),
            what: "only a directional critique keeps flagged observations".into(),
        });
    }
    for (k, z) in c.flagged.iter().enumerate() {
        if z.len() != domain.obs_dim() {
            return Err(DatasetError::Record {
                at: format!("critiques[{i}].flagged[{k}]"),
                what: format!(
                    "the observation has {} values; the `{}` domain observes {}",
                    z.len(),
                    domain.name,
                    domain.obs_dim()
                ),
            });
        }
        for (j, v) in z.iter().enumerate() {
            finite(format!("critiques[{i}].flagged[{k}][{j}]"), *v)?;
        }
    }
    Ok(())
}

/// The points: each of the domain's shape and within its limits, with a weight, a provenance
/// of a record the file holds (`advice_points`: the advice ids) and no other point's; and each
/// demonstration holding the points it says.
fn validate_points(
    file: &DatasetFile,
    mut advice_points: HashMap<u32, u32>,
) -> Result<(), DatasetError> {
    let domain = &file.domain;
    let values = |at: &str, z: &[f64], a: &[f64]| -> Result<(), DatasetError> {
        for (space, vals, dims) in [("z", z, &domain.observe), ("a", a, &domain.act)] {
            if vals.len() != dims.len() {
                return Err(DatasetError::Dimension {
                    at: format!("{at}.{space}"),
                    what: format!("{} values where the domain has {}", vals.len(), dims.len()),
                    expected: expected(domain),
                });
            }
        }
        check_point(domain, z, a, |space, k| format!("{at}.{space}[{k}]"))
    };
    let mut demo_points: HashMap<u32, u32> = file.demos.iter().map(|d| (d.id, 0)).collect();
    let mut seen: HashMap<Provenance, usize> = HashMap::new();
    for (i, p) in file.points.iter().enumerate() {
        let at = format!("points[{i}]");
        values(&at, &p.z, &p.a)?;
        check_weight(p.m, || format!("{at}.m"))?;
        let (count, what, id) = match p.provenance {
            Provenance::Demonstration { demo, .. } => {
                (demo_points.get_mut(&demo), "demonstration", demo)
            }
            Provenance::Advice { advice, .. } => (advice_points.get_mut(&advice), "advice", advice),
        };
        match count {
            Some(n) => *n += 1,
            None => {
                return Err(DatasetError::Dangling {
                    at: format!("{at}.provenance"),
                    what,
                    id,
                });
            }
        }
        if let Some(first) = seen.insert(p.provenance, i) {
            return Err(DatasetError::Record {
                at: format!("{at}.provenance"),
                what: format!("points {first} and {i} have the same provenance"),
            });
        }
    }
    for (i, d) in file.demos.iter().enumerate() {
        let n = demo_points.get(&d.id).copied().unwrap_or(0);
        if n != d.points {
            return Err(DatasetError::Record {
                at: format!("demos[{i}].points"),
                what: format!(
                    "demonstration {} says it has {} points; the file holds {n}",
                    d.id, d.points
                ),
            });
        }
        validate_times(i, d)?;
    }
    Ok(())
}

/// A demonstration's times, when it keeps them: a positive, finite period, or one finite time per
/// point from 0, never decreasing; not both.
fn validate_times(i: usize, d: &DemoRecord) -> Result<(), DatasetError> {
    let bad = |field: &str, what: String| {
        Err(DatasetError::Record {
            at: format!("demos[{i}].{field}"),
            what,
        })
    };
    match (d.period_s, &d.times_s) {
        (Some(_), Some(_)) => bad(
            "times_s",
            "a demonstration keeps `period_s` or `times_s`, not both".into(),
        ),
        (Some(p), None) if !(p.is_finite() && p > 0.0) => bad(
            "period_s",
            format!("the time between points must be a positive number of seconds, not {p}"),
        ),
        (None, Some(t)) if t.len() != d.points as usize => bad(
            "times_s",
            format!("{} times for {} points", t.len(), d.points),
        ),
        (None, Some(t)) if t.first().is_some_and(|&f| f != 0.0) => bad(
            "times_s",
            "the times are from the first point's: the first is 0".into(),
        ),
        (None, Some(t)) => match t
            .windows(2)
            .position(|w| !(w[1].is_finite() && w[1] >= w[0]))
        {
            Some(k) => bad(
                &format!("times_s[{}]", k + 1),
                format!(
                    "{} after {}: times are finite and never decrease",
                    t[k + 1],
                    t[k]
                ),
            ),
            None => Ok(()),
        },
        _ => Ok(()),
    }
}

/// The JSON file of a dataset.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct DatasetFile {
    format: String,
    domain: Domain,
    points: Vec<FilePoint>,
    demos: Vec<DemoRecord>,
    executions: Vec<ExecutionRecord>,
    advice: Vec<AdviceRecord>,
    critiques: Vec<CritiqueRecord>,
    next_id: u32,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FilePoint {
    z: Vec<f64>,
    a: Vec<f64>,
    m: f64,
    provenance: Provenance,
}
