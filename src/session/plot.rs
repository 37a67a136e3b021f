//! Pictures of an execution: a small character plot for the terminal and an SVG file (plotters).
//!
//! Both draw the robot's path in the plane with the start, the goal (positioning) or the ball's
//! path (interception), the current selection, and the chunks already critiqued or advised, so a
//! teacher can see what they are about to mark. No state; the session hands in a [`PlotView`].

use std::path::Path;

use plotters::prelude::*;

use crate::trace::{Chunk, Pose};

/// What to draw.
pub struct PlotView<'a> {
    pub title: String,
    pub path: &'a [Pose],
    pub goal: Option<Pose>,
    pub ball: Option<&'a [[f64; 2]]>,
    pub selection: Option<Chunk>,
    pub flagged: Vec<Chunk>,
    pub advised: Vec<Chunk>,
}

impl PlotView<'_> {
    fn bounds(&self) -> (f64, f64, f64, f64) {
        let mut xs: Vec<f64> = self.path.iter().map(|p| p.x_m).collect();
        let mut ys: Vec<f64> = self.path.iter().map(|p| p.y_m).collect();
        if let Some(g) = self.goal {
            xs.push(g.x_m);
            ys.push(g.y_m);
        }
        for b in self.ball.unwrap_or(&[]) {
            xs.push(b[0]);
            ys.push(b[1]);
        }
        let lo = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = |v: &[f64]| v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let (mut x0, mut x1, mut y0, mut y1) = (lo(&xs), hi(&xs), lo(&ys), hi(&ys));
        if !x0.is_finite() {
            (x0, x1, y0, y1) = (-1.0, 1.0, -1.0, 1.0);
        }
        // Keep a margin and a minimum extent so a short path is not blown up to fill the frame.
        let pad_x = ((x1 - x0) * 0.08).max(0.25);
        let pad_y = ((y1 - y0) * 0.08).max(0.25);
        (x0 - pad_x, x1 + pad_x, y0 - pad_y, y1 + pad_y)
    }

    fn in_any(chunks: &[Chunk], i: usize) -> bool {
        chunks.iter().any(|c| c.range().contains(&i))
    }
}

/// A character plot `width` x `height`: `.` path, `#` selection, `x` critiqued, `+` advised,
/// `S` start, `E` end, `G` goal, `o` ball.
pub fn ascii(view: &PlotView<'_>, width: usize, height: usize) -> String {
    let (width, height) = (width.max(8), height.max(4));
    let (x0, x1, y0, y1) = view.bounds();
    let mut grid = vec![vec![' '; width]; height];
    let cell = |x: f64, y: f64| -> (usize, usize) {
        let c = ((x - x0) / (x1 - x0) * (width - 1) as f64).round() as usize;
        let r = ((y1 - y) / (y1 - y0) * (height - 1) as f64).round() as usize;
        (r.min(height - 1), c.min(width - 1))
    };
    for b in view.ball.unwrap_or(&[]) {
        let (r, c) = cell(b[0], b[1]);
        grid[r][c] = 'o';
    }
    for (i, p) in view.path.iter().enumerate() {
        let (r, c) = cell(p.x_m, p.y_m);
        let mark = if view.selection.is_some_and(|s| s.range().contains(&i)) {
            '#'
        } else if PlotView::in_any(&view.flagged, i) {
            'x'
        } else if PlotView::in_any(&view.advised, i) {
            '+'
        } else {
            '.'
        };
        // Marks outrank plain path where points overlap.
        if grid[r][c] == ' ' || grid[r][c] == '.' || grid[r][c] == 'o' || mark == '#' {
            grid[r][c] = mark;
        }
    }
    if let Some(first) = view.path.first() {
        let (r, c) = cell(first.x_m, first.y_m);
        grid[r][c] = 'S';
    }
    if let Some(last) = view.path.last() {
        let (r, c) = cell(last.x_m, last.y_m);
        grid[r][c] = 'E';
    }
    if let Some(g) = view.goal {
        let (r, c) = cell(g.x_m, g.y_m);
        grid[r][c] = 'G';
    }
    let mut out = String::new();
    out.push_str(&format!("+{}+\n", "-".repeat(width)));
    for row in grid {
        out.push('|');
        out.extend(row);
        out.push_str("|\n");
    }
    out.push_str(&format!(
        "+{}+\n x {:.2}..{:.2} m, y {:.2}..{:.2} m   S start  E end  G goal  # selected  x critiqued  + advised  o ball\n",
        "-".repeat(width),
        x0,
        x1,
        y0,
        y1
    ));
    out
}

/// Why a plot could not be drawn or written.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
pub enum PlotError {
    #[error("cannot draw the plot `{path}`: {message}")]
    #[diagnostic(code(advise::plot::draw))]
    Draw { path: String, message: String },
    #[error(transparent)]
    #[diagnostic(transparent)]
    File(#[from] crate::files::FileError),
}

/// Write the execution as an SVG file.
pub fn svg(view: &PlotView<'_>, path: &Path) -> Result<(), PlotError> {
    let err = |e: &dyn std::fmt::Display| PlotError::Draw {
        path: path.display().to_string(),
        message: e.to_string(),
    };
    // Drawn into memory and written at once: a failed plot leaves no file.
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (800, 640)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let (x0, x1, y0, y1) = view.bounds();
        let mut chart = ChartBuilder::on(&root)
            .caption(&view.title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(44)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("x (m)")
            .y_desc("y (m)")
            .draw()
            .map_err(|e| err(&e))?;
        let xy = |p: &Pose| (p.x_m, p.y_m);
        chart
            .draw_series(LineSeries::new(
                view.path.iter().map(xy),
                BLUE.stroke_width(2),
            ))
            .map_err(|e| err(&e))?
            .label("path")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BLUE));
        if let Some(ball) = view.ball {
            chart
                .draw_series(LineSeries::new(
                    ball.iter().map(|b| (b[0], b[1])),
                    RGBColor(230, 140, 0).stroke_width(1),
                ))
                .map_err(|e| err(&e))?
                .label("ball")
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 16, y)], RGBColor(230, 140, 0))
                });
        }
        let segment = |c: &Chunk| -> Vec<(f64, f64)> {
            let end = c.end.min(view.path.len());
            view.path[c.start.min(end)..end].iter().map(xy).collect()
        };
        for (chunks, color, label) in [
            (&view.advised, GREEN, "advised"),
            (&view.flagged, RED, "critiqued"),
        ] {
            for (i, c) in chunks.iter().enumerate() {
                let s = chart
                    .draw_series(LineSeries::new(segment(c), color.stroke_width(5)))
                    .map_err(|e| err(&e))?;
                if i == 0 {
                    s.label(label).legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(5))
                    });
                }
            }
        }
        if let Some(sel) = view.selection {
            chart
                .draw_series(LineSeries::new(segment(&sel), MAGENTA.stroke_width(7)))
                .map_err(|e| err(&e))?
                .label(format!("selected {sel}"))
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 16, y)], MAGENTA.stroke_width(7))
                });
        }
        if let Some(first) = view.path.first() {
            chart
                .draw_series(std::iter::once(Circle::new(xy(first), 5, BLACK.filled())))
                .map_err(|e| err(&e))?;
        }
        if let Some(g) = view.goal {
            let (gx, gy) = (g.x_m, g.y_m);
            let arrow = 0.3;
            chart
                .draw_series(std::iter::once(Cross::new(
                    (gx, gy),
                    8,
                    BLACK.stroke_width(2),
                )))
                .map_err(|e| err(&e))?
                .label("goal")
                .legend(|(x, y)| Cross::new((x + 8, y), 5, BLACK));
            chart
                .draw_series(LineSeries::new(
                    [
                        (gx, gy),
                        (
                            gx + arrow * g.theta_rad.cos(),
                            gy + arrow * g.theta_rad.sin(),
                        ),
                    ],
                    BLACK.stroke_width(2),
                ))
                .map_err(|e| err(&e))?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    crate::files::write_bytes(path, svg.as_bytes())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(n: usize) -> Vec<Pose> {
        (0..n)
            .map(|i| Pose::new(i as f64 * 0.1, 0.0, 0.0))
            .collect()
    }

    #[test]
    fn ascii_marks_selection_start_end_and_goal() {
        let path = line(30);
        let view = PlotView {
            title: "t".into(),
            path: &path,
            goal: Some(Pose::new(3.5, 1.0, 0.0)),
            ball: None,
            selection: Some(Chunk { start: 10, end: 20 }),
            flagged: vec![],
            advised: vec![],
        };
        let s = ascii(&view, 40, 8);
        for c in ['S', 'E', 'G', '#', '.'] {
            assert!(s.contains(c), "{c} missing in\n{s}");
        }
    }

    #[test]
    fn svg_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("p.svg");
        let path = line(30);
        let view = PlotView {
            title: "run".into(),
            path: &path,
            goal: Some(Pose::new(3.5, 1.0, 0.5)),
            ball: None,
            selection: Some(Chunk { start: 2, end: 9 }),
            flagged: vec![Chunk { start: 12, end: 15 }],
            advised: vec![Chunk { start: 20, end: 25 }],
        };
        svg(&view, &p).unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.starts_with("<svg") && text.contains("selected 2..9"));
        assert!(svg(&view, &dir.path().join("no/such/dir/p.svg")).is_err());
        // A failed plot leaves nothing behind: no empty file, no temporary.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        let fifo = dir.path().join("fifo.svg");
        assert!(
            std::process::Command::new("mkfifo")
                .arg(&fifo)
                .status()
                .unwrap()
                .success()
        );
        assert!(matches!(
            svg(&view, &fifo),
            Err(PlotError::File(crate::files::FileError::NotRegular { .. }))
        ));
    }
}
