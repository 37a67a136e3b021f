//! The terminal's pictures: the path as characters and the actions as a strip, each marking the
//! selection and the chunks critiqued or advised.

use std::fmt::Write as _;

use super::*;

/// A character plot `width` x `height`: `.` path, `#` selection, `x` critiqued, `+` advised,
/// `S` start, `E` end, `G` goal, `o` ball, and what else the task draws: `*` a point or pose, `:`
/// a circle (a circle named `goal` has `G` at its centre). The axes have the same scale (a
/// character is about twice as tall as it is wide).
pub fn ascii(view: &PlotView<'_>, width: usize, height: usize) -> String {
    let (width, height) = (width.max(8), height.max(4));
    let (x0, x1, y0, y1) = equal_scale(bounds(&[view], false), width as u32, (height * 2) as u32);
    let mut grid = vec![vec![' '; width]; height];
    let cell = |x: f64, y: f64| -> (usize, usize) {
        let c = ((x - x0) / (x1 - x0) * (width - 1) as f64).round().max(0.0) as usize;
        let r = ((y1 - y) / (y1 - y0) * (height - 1) as f64)
            .round()
            .max(0.0) as usize;
        (r.min(height - 1), c.min(width - 1))
    };
    let drawn: Vec<&Drawn> = view.drawn.iter().filter(|d| d.is_finite()).collect();
    // Circles under everything: a ring of `:` (enough dots to close it at this size).
    for d in drawn.iter().filter(|d| d.shape == ShapeKind::Circle) {
        let (x, y) = d.at();
        let r = d.radius();
        let steps = 4 * (width + height);
        for k in 0..steps {
            let a = k as f64 * std::f64::consts::TAU / steps as f64;
            let (row, col) = cell(x + r * a.cos(), y + r * a.sin());
            grid[row][col] = ':';
        }
    }
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
        } else if PlotView::in_any(&view.teacher, i) {
            'T'
        } else {
            '.'
        };
        // Marks outrank plain path where points overlap.
        if matches!(grid[r][c], ' ' | '.' | 'o' | ':' | 'T') || mark == '#' {
            grid[r][c] = mark;
        }
    }
    for d in drawn
        .iter()
        .filter(|d| !d.is_goal() && d.shape != ShapeKind::Circle)
    {
        let (x, y) = d.at();
        let (r, c) = cell(x, y);
        grid[r][c] = '*';
    }
    if let Some(first) = view.path.first() {
        let (r, c) = cell(first.x_m, first.y_m);
        grid[r][c] = 'S';
    }
    if let Some(last) = view.path.last() {
        let (r, c) = cell(last.x_m, last.y_m);
        grid[r][c] = 'E';
    }
    for g in drawn.iter().filter(|d| d.is_goal()) {
        let (x, y) = g.at();
        let (r, c) = cell(x, y);
        grid[r][c] = 'G';
    }
    let mut out = String::new();
    out.push_str(&format!("+{}+\n", "-".repeat(width)));
    for row in grid {
        out.push('|');
        out.extend(row);
        out.push_str("|\n");
    }
    let span = (x1 - x0).max(y1 - y0);
    out.push_str(&format!(
        "+{}+\n x {}..{} m, y {}..{} m   S start  E end  G goal  # selected  x critiqued  + advised  o ball\n",
        "-".repeat(width),
        tick(x0, span),
        tick(x1, span),
        tick(y0, span),
        tick(y1, span)
    ));
    // The task's other drawings, by name (the goal is in the line above).
    let others: Vec<String> = drawn
        .iter()
        .filter(|d| !d.is_goal())
        .map(|d| {
            let mark = if d.shape == ShapeKind::Circle {
                ':'
            } else {
                '*'
            };
            format!("{mark} {}", d.name)
        })
        .collect();
    if !others.is_empty() {
        let _ = writeln!(out, " {}", others.join("  "));
    }
    if !view.teacher.is_empty() {
        let _ = writeln!(out, " T the teacher drove (takeover)");
    }
    out
}

/// The actions as a character strip `width` columns wide: one row per curve (each column the mean
/// of its points, scaled between the curve's least and greatest value), then a row marking the
/// selection `#`, critiqued `x` and advised `+` points, then a ruler of point indices.
pub fn strip(view: &PlotView<'_>, width: usize) -> String {
    const LEVELS: [char; 9] = [' ', '▁', '▂', '▃', '▄', '▅', '▆', '▇', '█'];
    let n = view.trace.len();
    let width = width.max(8);
    if n == 0 {
        return "(no points: no actions to show)\n".to_string();
    }
    let cols = width.min(n);
    let col_of = |c: usize| (c * n / cols)..((c + 1) * n / cols).max(c * n / cols + 1);
    let mut out = String::new();
    for s in view.action_series() {
        let means: Vec<f64> = (0..cols)
            .map(|c| {
                let r = col_of(c);
                let len = r.len() as f64;
                s.values[r].iter().sum::<f64>() / len
            })
            .collect();
        let lo = s.values.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = s.values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let row: String = means
            .iter()
            .map(|m| {
                if (hi - lo).is_nan() || hi <= lo {
                    LEVELS[4]
                } else {
                    let k = ((m - lo) / (hi - lo) * 7.0).round() as usize + 1;
                    LEVELS[k.min(8)]
                }
            })
            .collect();
        let span = (hi - lo).abs().max(lo.abs()).max(hi.abs());
        let _ = writeln!(
            out,
            "|{row}| {} {}..{}",
            s.label,
            tick(lo, span),
            tick(hi, span)
        );
    }
    let marks: String = (0..cols)
        .map(|c| {
            let r = col_of(c);
            let any = |chunks: &[Chunk]| {
                chunks
                    .iter()
                    .any(|k| r.clone().any(|i| k.range().contains(&i)))
            };
            if view.selection.is_some_and(|s| any(&[s])) {
                '#'
            } else if any(&view.flagged) {
                'x'
            } else if any(&view.advised) {
                '+'
            } else if any(&view.teacher) {
                'T'
            } else {
                ' '
            }
        })
        .collect();
    let teacher = if view.teacher.is_empty() {
        ""
    } else {
        "  T the teacher drove"
    };
    let _ = writeln!(out, "|{marks}| # selected  x critiqued  + advised{teacher}");
    // A ruler: the index of the first point of every 16th column.
    let mut ruler = vec![' '; cols + 8];
    for c in (0..cols).step_by(16) {
        for (k, ch) in col_of(c).start.to_string().chars().enumerate() {
            ruler[c + 1 + k] = ch;
        }
    }
    let ruler: String = ruler.into_iter().collect();
    let _ = writeln!(out, "{} point index (of {n})", ruler.trim_end());
    out
}
