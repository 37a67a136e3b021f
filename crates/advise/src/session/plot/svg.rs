//! The SVG pictures (plotters): paths (one execution, or two compared) and actions against point
//! index, with their legends.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::labels::{self, Candidate, Side};
use super::*;

/// A plotters error as text (the backend's error type is generic).
fn drawing<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// A legend entry's mark.
#[derive(Clone, Copy)]
enum Mark {
    Line(RGBColor, u32),
    Band(RGBColor, f64),
    Dot(RGBColor),
    Cross(RGBColor),
    Square(RGBColor),
    Ring(RGBColor),
    /// A dot with an arrow out of it (the robot's final pose).
    Arrow(RGBColor),
}

/// The characters of a legend entry's label per line: what the panel holds right of the mark at
/// 14 px sans-serif (about 7.5 px a character).
const LABEL_CHARS: usize = 24;

/// Draw the legend in its own panel beside the data, with text lines below the entries.
fn legend(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    entries: &[(Mark, String)],
    notes: &[String],
) -> Result<(), String> {
    let font = ("sans-serif", 14).into_font();
    let mut y = 40;
    for (mark, label) in entries {
        let (x0, x1) = (8, 34);
        match *mark {
            Mark::Line(c, w) => area
                .draw(&PathElement::new(vec![(x0, y), (x1, y)], c.stroke_width(w)))
                .map_err(drawing)?,
            Mark::Band(c, a) => area
                .draw(&Rectangle::new(
                    [(x0, y - 7), (x1, y + 7)],
                    c.mix(a).filled(),
                ))
                .map_err(drawing)?,
            Mark::Dot(c) => area
                .draw(&Circle::new(((x0 + x1) / 2, y), 5, c.filled()))
                .map_err(drawing)?,
            Mark::Cross(c) => area
                .draw(&Cross::new(((x0 + x1) / 2, y), 6, c.stroke_width(2)))
                .map_err(drawing)?,
            Mark::Square(c) => area
                .draw(&Rectangle::new(
                    [(x0 + 4, y - 8), (x1 - 4, y + 8)],
                    c.stroke_width(1),
                ))
                .map_err(drawing)?,
            Mark::Ring(_) => {}
            Mark::Arrow(c) => {
                area.draw(&Circle::new((x0 + 4, y), 4, c.filled()))
                    .map_err(drawing)?;
                for (a, b) in [
                    ((x0 + 4, y), (x1, y)),
                    ((x1 - 6, y - 5), (x1, y)),
                    ((x1 - 6, y + 5), (x1, y)),
                ] {
                    area.draw(&PathElement::new(vec![a, b], c.stroke_width(3)))
                        .map_err(drawing)?;
                }
            }
        }
        if let Mark::Ring(c) = *mark {
            area.draw(&Circle::new(((x0 + x1) / 2, y), 7, c.stroke_width(1)))
                .map_err(drawing)?;
        }
        // Long labels wrap within the panel (the panel's right edge is the picture's).
        for (i, line) in wrap(label, LABEL_CHARS).into_iter().enumerate() {
            if i > 0 {
                y += 17;
            }
            area.draw(&Text::new(line, (x1 + 8, y - 7), font.clone()))
                .map_err(drawing)?;
        }
        y += 24;
    }
    y += 8;
    for note in notes {
        for line in wrap(note, 30) {
            area.draw(&Text::new(line, (8, y - 7), font.clone()))
                .map_err(drawing)?;
            y += 18;
        }
    }
    Ok(())
}

/// Break `s` into lines of at most `width` characters at spaces.
fn wrap(s: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for word in s.split(' ') {
        match lines.last_mut() {
            Some(l) if l.chars().count() + 1 + word.chars().count() <= width => {
                l.push(' ');
                l.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    lines
}

fn chunk_label(kind: &str, chunks: &[Chunk]) -> String {
    let list: Vec<String> = chunks.iter().take(4).map(|c| c.to_string()).collect();
    let more = if chunks.len() > 4 { ", ..." } else { "" };
    format!("{kind} {}{more}", list.join(", "))
}

/// The path plot: one execution with its marks, or several overlaid (`colors` one per view).
pub(super) fn render_paths(
    views: &[&PlotView<'_>],
    names: &[String],
    title: &str,
) -> Result<String, String> {
    let colors = [PATH, AFTER];
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(drawing)?;
        let root = root.titled(title, ("sans-serif", 20)).map_err(drawing)?;
        let (main, side) = root.split_horizontally(SIZE.0 - LEGEND_W);
        let (mut chart, px_per_m) = path_chart(&main, views)?;
        let mut entries = draw_arena(&mut chart, views)?;
        let mut notes: Vec<String> = Vec::new();
        let single = views.len() == 1;
        for (k, v) in views.iter().enumerate() {
            let color = colors[k % colors.len()];
            // Under the path: the selection as a wide band, then advised, then critiqued on top
            // of everything so a critique is never hidden.
            if single {
                entries.extend(draw_selection(&mut chart, v)?);
            }
            chart
                .draw_series(LineSeries::new(
                    v.path.iter().map(xy),
                    color.stroke_width(2),
                ))
                .map_err(drawing)?;
            if let Some(ball) = v.ball {
                draw_ball(&mut chart, ball)?;
            }
            if single {
                entries.extend(draw_chunks(&mut chart, v)?);
            }
            draw_marks(&mut chart, v, color)?;
            // The capture distance around where the robot ended: the ball inside it was caught.
            if let (Some(a), Some(last)) = (v.arena, v.path.last()) {
                let r = (a.capture_m * px_per_m).round().max(2.0) as u32;
                chart
                    .draw_series(std::iter::once(Circle::new(
                        xy(last),
                        r,
                        color.stroke_width(1),
                    )))
                    .map_err(drawing)?;
            }
            entries.push((Mark::Line(color, 2), names[k].clone()));
            if let Some(o) = &v.outcome {
                notes.push(if single {
                    o.clone()
                } else {
                    format!("{}: {o}", ["before", "after"][k % 2])
                });
            }
        }
        let drawn_entries = draw_shapes(&mut chart, views)?;
        number_points(&mut chart, views, &colors)?;
        entries.push((Mark::Dot(BLACK), "start".into()));
        entries.push((Mark::Arrow(PATH), "end, and the heading there".into()));
        entries.push((
            Mark::Dot(PATH),
            format!("every {INDEX_EVERY}th point (numbered where there is room)"),
        ));
        entries.extend(drawn_entries);
        if views.iter().any(|v| v.ball.is_some()) {
            entries.push((
                Mark::Line(BALL, 2),
                format!("ball (dots: every {INDEX_EVERY}th point; big: where it ended)"),
            ));
        }
        legend(&side, &entries, &notes)?;
        root.present().map_err(drawing)?;
    }
    Ok(svg)
}

/// The chart of a path plot.
type PathChart<'a, 'b> = ChartContext<
    'a,
    SVGBackend<'b>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// A pose's position, as the chart places it.
fn xy(p: &Pose) -> (f64, f64) {
    (p.x_m, p.y_m)
}

/// The chart on `main` holding every view's path (and arrows) at equal scale, its axes drawn,
/// and its pixels per metre.
fn path_chart<'a, 'b>(
    main: &'a DrawingArea<SVGBackend<'b>, Shift>,
    views: &[&PlotView<'_>],
) -> Result<(PathChart<'a, 'b>, f64), String> {
    let build = |r: (f64, f64, f64, f64)| {
        ChartBuilder::on(main)
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(56)
            .build_cartesian_2d(r.0..r.1, r.2..r.3)
    };
    let (pw, ph) = build((0.0, 1.0, 0.0, 1.0))
        .map_err(drawing)?
        .plotting_area()
        .dim_in_pixel();
    let (x0, x1, y0, y1) = equal_scale(bounds(views, true), pw, ph);
    let mut chart = build((x0, x1, y0, y1)).map_err(drawing)?;
    let span = (x1 - x0).max(y1 - y0);
    chart
        .configure_mesh()
        .x_desc("x (m)")
        .y_desc("y (m)")
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 14))
        .x_label_formatter(&|v| tick(*v, span))
        .y_label_formatter(&|v| tick(*v, span))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(drawing)?;
    Ok((chart, f64::from(pw) / (x1 - x0)))
}

/// Draw the first view's arena, if any (its edge); returns its legend entries, the edge's and
/// the capture distance's.
fn draw_arena(
    chart: &mut PathChart<'_, '_>,
    views: &[&PlotView<'_>],
) -> Result<Vec<(Mark, String)>, String> {
    let mut entries: Vec<(Mark, String)> = Vec::new();
    if let Some(a) = views.iter().find_map(|v| v.arena) {
        let h = a.half_m;
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(-h, -h), (h, h)],
                ARENA.stroke_width(2),
            )))
            .map_err(drawing)?;
        entries.push((Mark::Square(ARENA), format!("arena edge (±{h} m)")));
        entries.push((
            Mark::Ring(PATH),
            format!("capture distance ({} m)", a.capture_m),
        ));
    }
    Ok(entries)
}

/// The positions of `v`'s path in chunk `c` (clipped to the path).
fn segment(v: &PlotView<'_>, c: &Chunk) -> Vec<(f64, f64)> {
    let end = c.end.min(v.path.len());
    v.path[c.start.min(end)..end].iter().map(xy).collect()
}

/// Draw `v`'s selection, if any, as a wide band; returns its legend entry.
fn draw_selection(
    chart: &mut PathChart<'_, '_>,
    v: &PlotView<'_>,
) -> Result<Option<(Mark, String)>, String> {
    let Some(sel) = v.selection else {
        return Ok(None);
    };
    chart
        .draw_series(LineSeries::new(
            segment(v, &sel),
            SELECTED.mix(0.5).stroke_width(12),
        ))
        .map_err(drawing)?;
    Ok(Some((Mark::Band(SELECTED, 0.5), format!("selected {sel}"))))
}

/// Draw the ball's path with its index marks, and where it ended.
fn draw_ball(chart: &mut PathChart<'_, '_>, ball: &[[f64; 2]]) -> Result<(), String> {
    chart
        .draw_series(LineSeries::new(
            ball.iter().map(|b| (b[0], b[1])),
            BALL.stroke_width(2),
        ))
        .map_err(drawing)?;
    // The ball's index marks, at the robot's stride: where the ball was at point N.
    chart
        .draw_series(
            ball.iter()
                .step_by(INDEX_EVERY)
                .map(|b| Circle::new((b[0], b[1]), 2, BALL.filled())),
        )
        .map_err(drawing)?;
    if let Some(b) = ball.last() {
        chart
            .draw_series(std::iter::once(Circle::new((b[0], b[1]), 4, BALL.filled())))
            .map_err(drawing)?;
    }
    Ok(())
}

/// Draw `v`'s advised chunks, then its critiqued ones over them; returns a legend entry for
/// each kind present.
fn draw_chunks(
    chart: &mut PathChart<'_, '_>,
    v: &PlotView<'_>,
) -> Result<Vec<(Mark, String)>, String> {
    let mut entries: Vec<(Mark, String)> = Vec::new();
    for (chunks, c, kind) in [
        (&v.teacher, TEACHER, "the teacher drove"),
        (&v.advised, ADVISED, "advised"),
        (&v.flagged, CRITIQUED, "critiqued"),
    ] {
        for ch in chunks.iter() {
            chart
                .draw_series(LineSeries::new(segment(v, ch), c.stroke_width(5)))
                .map_err(drawing)?;
        }
        if !chunks.is_empty() {
            entries.push((Mark::Line(c, 5), chunk_label(kind, chunks)));
        }
    }
    Ok(entries)
}

/// Draw `v`'s marks: a dot every [`INDEX_EVERY`] points (numbered by [`number_points`] after
/// every layer), its start, and where it ended with the heading there.
fn draw_marks(
    chart: &mut PathChart<'_, '_>,
    v: &PlotView<'_>,
    color: RGBColor,
) -> Result<(), String> {
    chart
        .draw_series(
            v.path
                .iter()
                .step_by(INDEX_EVERY)
                .map(|p| Circle::new(xy(p), 3, color.filled())),
        )
        .map_err(drawing)?;
    if let Some(first) = v.path.first() {
        chart
            .draw_series(std::iter::once(Circle::new(xy(first), 5, BLACK.filled())))
            .map_err(drawing)?;
    }
    // Where the robot ended and which way it faced, to compare with the goal's heading.
    if let Some(last) = v.path.last().filter(|p| p.theta_rad.is_finite()) {
        let (x, y) = xy(last);
        let h = last.theta_rad;
        let tip = (x + HEADING_ARROW_M * h.cos(), y + HEADING_ARROW_M * h.sin());
        chart
            .draw_series(std::iter::once(Circle::new((x, y), 4, color.filled())))
            .map_err(drawing)?;
        chart
            .draw_series(LineSeries::new([(x, y), tip], color.stroke_width(3)))
            .map_err(drawing)?;
        // An open head at the tip: two short strokes back at 150 degrees.
        let head = HEADING_ARROW_M * 0.35;
        for side in [-1.0, 1.0] {
            let a = h + side * 2.6;
            chart
                .draw_series(LineSeries::new(
                    [tip, (tip.0 + head * a.cos(), tip.1 + head * a.sin())],
                    color.stroke_width(3),
                ))
                .map_err(drawing)?;
        }
    }
    Ok(())
}

/// Draw what the task draws for each view's goal (its `draw` clauses): the goal in black, other
/// shapes in grey; a pose as a cross with a heading arrow, a point as a cross, a circle as a ring.
/// Returns the legend's entries, one per name.
fn draw_shapes(
    chart: &mut PathChart<'_, '_>,
    views: &[&PlotView<'_>],
) -> Result<Vec<(Mark, String)>, String> {
    let mut entries: Vec<(Mark, String)> = Vec::new();
    let mut named: Vec<&str> = Vec::new();
    for d in views
        .iter()
        .flat_map(|v| &v.drawn)
        .filter(|d| d.is_finite())
    {
        let color = if d.is_goal() { BLACK } else { DRAWN };
        let (x, y) = d.at();
        match d.shape {
            ShapeKind::Pose | ShapeKind::Point => {
                chart
                    .draw_series(std::iter::once(Cross::new(
                        (x, y),
                        8,
                        color.stroke_width(2),
                    )))
                    .map_err(drawing)?;
            }
            ShapeKind::Circle => {
                let r = d.radius();
                let ring = (0..=72).map(|k| {
                    let a = f64::from(k) * std::f64::consts::TAU / 72.0;
                    (x + r * a.cos(), y + r * a.sin())
                });
                chart
                    .draw_series(LineSeries::new(ring, color.stroke_width(1)))
                    .map_err(drawing)?;
            }
        }
        if let Some(h) = d.heading() {
            let arrow = HEADING_ARROW_M;
            chart
                .draw_series(LineSeries::new(
                    [(x, y), (x + arrow * h.cos(), y + arrow * h.sin())],
                    color.stroke_width(2),
                ))
                .map_err(drawing)?;
        }
        if named.contains(&d.name.as_str()) {
            continue;
        }
        named.push(&d.name);
        entries.push(match d.shape {
            ShapeKind::Pose => (Mark::Cross(color), format!("{} (and heading)", d.name)),
            ShapeKind::Point => (Mark::Cross(color), d.name.clone()),
            ShapeKind::Circle => (
                Mark::Ring(color),
                format!("{} (circle, r {} m)", d.name, tick(d.radius(), 1.0)),
            ),
        });
    }
    Ok(entries)
}

/// Number the index marks of every path (the robot's, then the ball's), thinned so that no two
/// labels overlap ([`labels::place`]); a single run's selection ends are always numbered.
fn number_points(
    chart: &mut PathChart<'_, '_>,
    views: &[&PlotView<'_>],
    colors: &[RGBColor],
) -> Result<(), String> {
    let single = views.len() == 1;
    // The crosses of goals and points are read too: no number covers one.
    let mut taken: Vec<labels::LabelBox> = views
        .iter()
        .flat_map(|v| &v.drawn)
        .filter(|d| d.is_finite() && !matches!(d.shape, ShapeKind::Circle))
        .map(|d| {
            let (x, y) = chart.backend_coord(&d.at());
            labels::LabelBox {
                x: x - 9,
                y: y - 9,
                w: 19,
                h: 19,
            }
        })
        .collect();
    for (k, v) in views.iter().enumerate() {
        let xy: Vec<(f64, f64)> = v.path.iter().map(|p| (p.x_m, p.y_m)).collect();
        let ends: Vec<usize> = v
            .selection
            .filter(|_| single && !xy.is_empty())
            .map(|s| vec![s.start.min(xy.len() - 1), s.end.min(xy.len() - 1)])
            .unwrap_or_default();
        let side = if k % 2 == 0 { Side::Below } else { Side::Above };
        let color = colors[k % colors.len()];
        label_marks(chart, &xy, &ends, side, color, &mut taken)?;
    }
    for v in views {
        if let Some(ball) = v.ball {
            let xy: Vec<(f64, f64)> = ball.iter().map(|b| (b[0], b[1])).collect();
            label_marks(chart, &xy, &[], Side::Above, BALL, &mut taken)?;
        }
    }
    Ok(())
}

/// Number every [`INDEX_EVERY`]-th point of `xy` and the points `keep` (in the selection's
/// colour), where their labels clear the ones in `taken`.
fn label_marks(
    chart: &mut PathChart<'_, '_>,
    xy: &[(f64, f64)],
    keep: &[usize],
    side: Side,
    color: RGBColor,
    taken: &mut Vec<labels::LabelBox>,
) -> Result<(), String> {
    let cands: Vec<Candidate> = keep
        .iter()
        .map(|&i| (i, true))
        .chain(
            (0..xy.len())
                .step_by(INDEX_EVERY)
                .filter(|i| !keep.contains(i))
                .map(|i| (i, false)),
        )
        .map(|(index, keep)| Candidate {
            index,
            at: chart.backend_coord(&xy[index]),
            keep,
        })
        .collect();
    for p in labels::place(&cands, side, taken) {
        let at = chart.backend_coord(&xy[p.index]);
        let c = if p.keep { SELECTED } else { color };
        chart
            .draw_series(std::iter::once(
                // A pale box under the number keeps it readable where it lies on a path.
                EmptyElement::at(xy[p.index])
                    + Rectangle::new(
                        [
                            (p.bx.x - at.0, p.bx.y - at.1),
                            (p.bx.x - at.0 + p.bx.w, p.bx.y - at.1 + p.bx.h - 1),
                        ],
                        WHITE.mix(0.75).filled(),
                    )
                    + Text::new(
                        p.index.to_string(),
                        (p.bx.x - at.0, p.bx.y - at.1),
                        ("sans-serif", 12).into_font().color(&c),
                    ),
            ))
            .map_err(drawing)?;
    }
    Ok(())
}

/// The actions plot: one panel per curve against point index, chunks shaded.
pub(super) fn render_actions(view: &PlotView<'_>) -> Result<String, String> {
    let series = view.action_series();
    let n = view.trace.len();
    let mut svg = String::new();
    {
        let height = 120 + 170 * series.len().max(1) as u32;
        let root = SVGBackend::with_string(&mut svg, (SIZE.0, height)).into_drawing_area();
        root.fill(&WHITE).map_err(drawing)?;
        let root = root
            .titled(&view.title, ("sans-serif", 20))
            .map_err(drawing)?;
        let (main, side) = root.split_horizontally(SIZE.0 - LEGEND_W);
        let panels = main.split_evenly((series.len().max(1), 1));
        let t0 = view.trace.t.first().copied().unwrap_or(0.0);
        let time_of = |i: usize| view.trace.t.get(i).map(|t| t - t0);
        let x_max = n.max(1) as f64;
        for (k, (s, panel)) in series.iter().zip(&panels).enumerate() {
            let lo = s.values.iter().copied().fold(0.0_f64, f64::min);
            let hi = s.values.iter().copied().fold(0.0_f64, f64::max);
            let pad = ((hi - lo) * 0.08).max(1e-3);
            let (y0, y1) = (lo - pad, hi + pad);
            let mut chart = ChartBuilder::on(panel)
                .margin(8)
                .x_label_area_size(44)
                .y_label_area_size(64)
                .build_cartesian_2d(0.0..x_max, y0..y1)
                .map_err(drawing)?;
            let span = (y1 - y0).max(y0.abs()).max(y1.abs());
            let last = k + 1 == series.len();
            chart
                .configure_mesh()
                .x_labels(10)
                .y_labels(6)
                .x_label_formatter(&|v| {
                    let i = v.round().max(0.0) as usize;
                    match time_of(i) {
                        Some(t) if last => format!("{i} ({t:.1} s)"),
                        _ => i.to_string(),
                    }
                })
                .y_label_formatter(&|v| fine_tick(*v, span))
                .x_desc(if last {
                    "point index (time since the start)"
                } else {
                    "point index"
                })
                .y_desc(s.label.as_str())
                .label_style(("sans-serif", 13))
                .axis_desc_style(("sans-serif", 14))
                .light_line_style(WHITE.mix(0.0))
                .draw()
                .map_err(drawing)?;
            let band = |c: &Chunk, color: RGBColor, alpha: f64| {
                Rectangle::new(
                    [(c.start as f64, y0), (c.end as f64, y1)],
                    color.mix(alpha).filled(),
                )
            };
            // Critiqued on top: drawn last.
            if let Some(sel) = view.selection {
                chart
                    .draw_series(std::iter::once(band(&sel, SELECTED, 0.25)))
                    .map_err(drawing)?;
            }
            chart
                .draw_series(view.teacher.iter().map(|c| band(c, TEACHER, 0.25)))
                .map_err(drawing)?;
            chart
                .draw_series(view.advised.iter().map(|c| band(c, ADVISED, 0.25)))
                .map_err(drawing)?;
            chart
                .draw_series(view.flagged.iter().map(|c| band(c, CRITIQUED, 0.3)))
                .map_err(drawing)?;
            chart
                .draw_series(LineSeries::new([(0.0, 0.0), (x_max, 0.0)], BLACK.mix(0.4)))
                .map_err(drawing)?;
            chart
                .draw_series(LineSeries::new(
                    s.values.iter().enumerate().map(|(i, v)| (i as f64, *v)),
                    PATH.stroke_width(2),
                ))
                .map_err(drawing)?;
        }
        let mut entries = vec![(Mark::Line(PATH, 2), "action".to_string())];
        if let Some(sel) = view.selection {
            entries.push((Mark::Band(SELECTED, 0.25), format!("selected {sel}")));
        }
        if !view.teacher.is_empty() {
            entries.push((
                Mark::Band(TEACHER, 0.25),
                chunk_label("the teacher drove", &view.teacher),
            ));
        }
        if !view.advised.is_empty() {
            entries.push((
                Mark::Band(ADVISED, 0.25),
                chunk_label("advised", &view.advised),
            ));
        }
        if !view.flagged.is_empty() {
            entries.push((
                Mark::Band(CRITIQUED, 0.3),
                chunk_label("critiqued", &view.flagged),
            ));
        }
        let mut notes = Vec::new();
        if let Some(o) = &view.outcome {
            notes.push(o.clone());
        }
        // What the task draws on the path plot, as numbers: the goal this run drove to.
        for d in &view.drawn {
            let values: Vec<String> = d.values.iter().map(|v| tick(*v, 1.0)).collect();
            notes.push(format!(
                "{}: {} ({})",
                d.name,
                d.shape.word(),
                values.join(", ")
            ));
        }
        notes.push(format!("{n} points; `select A..B` by the index axis"));
        legend(&side, &entries, &notes)?;
        root.present().map_err(drawing)?;
    }
    Ok(svg)
}
