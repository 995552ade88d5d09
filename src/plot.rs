//! Figures as SVG and PNG, with no plotting dependency.
//!
//! A [`Figure`] is a stack of [`Panel`]s over one shared x axis, each panel with its own y axis,
//! title and legend: the layout of the paper's time-series figures (joint moments, force
//! components, deviations, joint coordinates). [`to_svg`] writes SVG 1.1 text; [`to_png`]
//! rasterises the same layout into an RGB buffer (anti-aliased lines, a built-in 5×7 bitmap font)
//! and encodes it as a PNG with its own deflate encoder (LZ77 matching, fixed Huffman codes).
//!
//! Axis ranges come from the finite data only: a point whose `x` or `y` is NaN or infinite is
//! skipped and breaks its line. Ticks are "nice" values (1, 2 or 5 × 10^k). Before drawing, a
//! series keeps only the first, lowest, highest and last point of each run of points falling in
//! one pixel column, so a 100 000-point series costs a few thousand points and looks the same.
//! Both outputs are deterministic: the same figure and size give the same bytes.

use std::fmt::Write as _;

/// One line of a panel: `y` against `x`.
///
/// Points whose `x` or `y` is not finite are skipped and break the line. If `x` and `y` differ
/// in length, the values past the shorter one are ignored.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// Abscissae, on the figure's shared axis (e.g. time in s).
    pub x: Vec<f64>,
    /// Ordinates, on the panel's axis.
    pub y: Vec<f64>,
    /// Index into the fixed 10-colour palette (which repeats after 10); `None` takes the
    /// series' position in its panel.
    pub color: Option<usize>,
    /// How the line is drawn.
    pub stroke: Stroke,
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Stroke {
    /// A line of the figure's width in the series' colour.
    #[default]
    Line,
    /// Four times as wide in a pale tint of the colour, drawn under every `Line` of its panel:
    /// a reference (e.g. the true value) that stays visible beneath the line that tracks it.
    Band,
}

/// One plot area with its own y axis, title and legend.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Panel {
    /// Written above the plot area; may be empty.
    pub title: String,
    /// Written vertically left of the y axis; may be empty.
    pub y_label: String,
    /// The lines, in legend order; bands are drawn first, then the lines.
    pub series: Vec<Series>,
}

/// Panels stacked top to bottom over one shared x axis.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Figure {
    /// Written at the top; may be empty.
    pub title: String,
    /// Written under the last panel, below its tick labels; may be empty.
    pub x_label: String,
    /// The panels, top first. A figure with no panel draws only its title.
    pub panels: Vec<Panel>,
}

/// The figure as an SVG 1.1 document, `width` × `height` pixels (each clamped to 64..=8192).
///
/// One `<polyline>` per series, or one per unbroken run when non-finite points split it; all
/// text is escaped. Text is laid out for about 0.6 em per character, so labels fit in a
/// sans-serif or monospace font.
pub fn to_svg(fig: &Figure, width: u32, height: u32) -> String {
    let l = layout(fig, width, height);
    let mut c = SvgCanvas::default();
    let _ = writeln!(
        c.out,
        "<?xml version=\"1.0\" encoding=\"UTF-8\" standalone=\"no\"?>\n\
         <svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"{w}\" height=\"{h}\" \
         viewBox=\"0 0 {w} {h}\" font-family=\"DejaVu Sans, Helvetica, Arial, sans-serif\">",
        w = l.w,
        h = l.h
    );
    draw(fig, &l, &mut c);
    c.out.push_str("</svg>\n");
    c.out
}

/// The figure as a PNG file (8-bit RGB), `width` × `height` pixels (each clamped to 64..=8192).
///
/// Compressed losslessly: a 1200 × 900 figure, 3.2 MB of pixels, takes about 45 kB with one line
/// and 265 kB with four panels of three wiggly curves each. Characters outside printable ASCII are
/// drawn as `?`.
pub fn to_png(fig: &Figure, width: u32, height: u32) -> Vec<u8> {
    let r = render(fig, width, height);
    encode_png(r.w, r.h, &r.rgb)
}

// ---------------------------------------------------------------------------------------------
// Layout, shared by both outputs
// ---------------------------------------------------------------------------------------------

type Rgb = [u8; 3];

const WHITE: Rgb = [255, 255, 255];
const BLACK: Rgb = [0, 0, 0];
const GRID: Rgb = [225, 225, 225];
const LEGEND_EDGE: Rgb = [170, 170, 170];
/// Matplotlib's "tab10".
const PALETTE: [Rgb; 10] = [
    [0x1f, 0x77, 0xb4],
    [0xff, 0x7f, 0x0e],
    [0x2c, 0xa0, 0x2c],
    [0xd6, 0x27, 0x28],
    [0x94, 0x67, 0xbd],
    [0x8c, 0x56, 0x4b],
    [0xe3, 0x77, 0xc2],
    [0x7f, 0x7f, 0x7f],
    [0xbc, 0xbd, 0x22],
    [0x17, 0xbe, 0xcf],
];
const MIN_SIZE: u32 = 64;
const MAX_SIZE: u32 = 8192;

#[derive(Debug, Clone, Copy, PartialEq)]
struct Rect {
    x: f64,
    y: f64,
    w: f64,
    h: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Anchor {
    Start,
    Middle,
    End,
}

/// How a string is drawn: glyph scale (a character is 6 × `size` px wide, 7 × `size` px tall),
/// horizontal anchor, direction (vertical reads bottom to top) and colour.
#[derive(Debug, Clone, Copy)]
struct Text {
    size: u32,
    anchor: Anchor,
    vertical: bool,
    color: Rgb,
}

/// One axis: its range, tick step, ticks (inside the range) and their labels.
#[derive(Debug, Clone)]
struct Axis {
    lo: f64,
    hi: f64,
    step: f64,
    ticks: Vec<f64>,
    labels: Vec<String>,
}

impl Axis {
    /// Ticks on `range` at the nice step closest above `range / target`.
    #[cfg(test)]
    fn new((lo, hi): (f64, f64), target: usize) -> Axis {
        let raw = (hi / 2.0 - lo / 2.0) / target.max(1) as f64 * 2.0;
        Axis::with_step(lo, hi, nice_step(raw))
    }

    fn with_step(lo: f64, hi: f64, step: Option<f64>) -> Axis {
        let (step, ticks) = match step {
            Some(step) => (step, ticks_with_step(lo, hi, step)),
            None => (0.0, Vec::new()),
        };
        let labels = tick_labels(&ticks, step);
        Axis {
            lo,
            hi,
            step,
            ticks,
            labels,
        }
    }

    /// Ticks on `range`, drawn `len` px long, at the smallest nice step that puts them at least
    /// `min_gap` px apart and, given a character width `cw`, leaves two characters between
    /// labels written side by side; but never fewer than two ticks if a finer step had them.
    fn fitted((lo, hi): (f64, f64), len: f64, min_gap: f64, cw: Option<f64>) -> Axis {
        let span = (hi / 2.0 - lo / 2.0) * 2.0;
        let mut a = Axis::with_step(lo, hi, nice_step(span / len.max(1.0) * min_gap));
        // A step as long as the range leaves one tick or none (±4.4 with a step of 5): finer
        // steps, crowded or not, until there are two.
        for _ in 0..12 {
            if a.ticks.len() >= 2 || a.step <= 0.0 {
                break;
            }
            a = Axis::with_step(lo, hi, nice_step(a.step / 2.5));
        }
        for _ in 0..6 {
            let need = cw.map_or(min_gap, |cw| min_gap.max((a.max_label_chars() + 2) as f64 * cw));
            if a.ticks.is_empty() || a.step / span * len >= need * (1.0 - 1e-9) {
                break;
            }
            let wider = Axis::with_step(lo, hi, nice_step(a.step * 1.5));
            if wider.ticks.len() < 2 && a.ticks.len() >= 2 {
                // Two crowded ticks say more than one or none.
                break;
            }
            a = wider;
        }
        a
    }

    /// `v` mapped linearly from `[lo, hi]` onto `[a, b]` (halved first, so a huge range cannot
    /// overflow).
    fn map(&self, v: f64, a: f64, b: f64) -> f64 {
        let t = (v / 2.0 - self.lo / 2.0) / (self.hi / 2.0 - self.lo / 2.0);
        a + t * (b - a)
    }

    fn max_label_chars(&self) -> usize {
        self.labels.iter().map(|s| s.chars().count()).max().unwrap_or(0)
    }
}

/// The smallest of 1, 2, 5 × 10^k that is at least `raw`.
fn nice_step(raw: f64) -> Option<f64> {
    if !(raw.is_finite() && raw > 0.0) {
        return None;
    }
    let mut k = raw.log10().floor() as i32;
    let f = raw / 10f64.powi(k);
    let m = if f <= 1.0 + 1e-9 {
        1.0
    } else if f <= 2.0 + 1e-9 {
        2.0
    } else if f <= 5.0 + 1e-9 {
        5.0
    } else {
        k += 1;
        1.0
    };
    let step = m * 10f64.powi(k);
    (step.is_finite() && step > 0.0).then_some(step)
}

/// The multiples of `step` in `[lo, hi]` (none if there would be more than 200).
fn ticks_with_step(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    let i0 = (lo / step - 1e-9).ceil();
    let i1 = (hi / step + 1e-9).floor();
    if !(i0.is_finite() && i1.is_finite()) || i1 < i0 || i1 - i0 > 200.0 {
        return Vec::new();
    }
    // `+ 0.0` turns -0 into 0.
    (0..=(i1 - i0) as i64)
        .map(|j| (i0 + j as f64) * step + 0.0)
        .collect()
}

/// Labels with just enough decimals for `step`; exponent notation for |values| ≥ 1e6 or steps
/// below 1e-4.
fn tick_labels(ticks: &[f64], step: f64) -> Vec<String> {
    if ticks.is_empty() {
        return Vec::new();
    }
    let k = (step.log10() + 1e-9).floor() as i32;
    let max_abs = ticks.iter().fold(0.0f64, |m, t| m.max(t.abs()));
    if max_abs >= 1e6 || k < -4 {
        let top = if max_abs > 0.0 {
            (max_abs.log10() + 1e-9).floor() as i32
        } else {
            k
        };
        let digits = (top - k).clamp(0, 15) as usize;
        ticks
            .iter()
            .map(|&t| {
                if t == 0.0 {
                    "0".to_string()
                } else {
                    format!("{t:.digits$e}")
                }
            })
            .collect()
    } else {
        let d = (-k).max(0) as usize;
        ticks.iter().map(|&t| format!("{t:.d$}")).collect()
    }
}

/// The points of `s` whose coordinates are both finite.
fn finite_points(s: &Series) -> impl Iterator<Item = (f64, f64)> + '_ {
    s.x.iter()
        .zip(&s.y)
        .map(|(&x, &y)| (x, y))
        .filter(|(x, y)| x.is_finite() && y.is_finite())
}

fn min_max(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values.fold(None, |acc, v| match acc {
        None => Some((v, v)),
        Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
    })
}

/// An axis range for data spanning `lo_hi`, widened by `pad` of the span on each side. No data
/// gives [0, 1]; a flat span gets ±10 % of its value (±1 around 0).
fn axis_range(lo_hi: Option<(f64, f64)>, pad: f64) -> (f64, f64) {
    let Some((lo, hi)) = lo_hi else {
        return (0.0, 1.0);
    };
    let mid = lo / 2.0 + hi / 2.0;
    if hi - lo <= mid.abs() * 1e-12 {
        let d = if mid == 0.0 { 1.0 } else { mid.abs() * 0.1 };
        return (mid - d, mid + d);
    }
    let p = (hi / 2.0 - lo / 2.0) * 2.0 * pad;
    ((lo - p).max(f64::MIN), (hi + p).min(f64::MAX))
}

/// Where everything goes, in pixels.
#[derive(Debug)]
struct Layout {
    w: u32,
    h: u32,
    /// Text scale: 1 up to 1000 × 750 px, 2 up to 1500 × 1125, and so on up to 4.
    s: u32,
    cw: f64,
    lh: f64,
    pad: f64,
    tick: f64,
    /// Data line width.
    lw: f64,
    /// Frame and tick width.
    frame: f64,
    title_mid: f64,
    x_axis: Axis,
    panels: Vec<(Rect, Axis)>,
    y_label_x: f64,
    x_ticks_mid: f64,
    x_label_mid: f64,
    legend_w: f64,
    legend_chars: usize,
    /// Legend rows that fit beside one plot area.
    legend_rows: usize,
}

fn layout(fig: &Figure, width: u32, height: u32) -> Layout {
    let (wu, hu) = (width.clamp(MIN_SIZE, MAX_SIZE), height.clamp(MIN_SIZE, MAX_SIZE));
    let (w, h) = (f64::from(wu), f64::from(hu));
    let s = ((w.min(h * 4.0 / 3.0) / 500.0).floor() as u32).clamp(1, 4);
    let sf = f64::from(s);
    let (cw, lh, pad, tick) = (6.0 * sf, 11.0 * sf, 4.0 * sf, 4.0 * sf);
    let ts = f64::from(s + 1);

    // Vertical: title, then per panel a title band and the plot area, then the x tick labels
    // and x label under the last one.
    let (top, title_mid) = if fig.title.is_empty() {
        (2.0 * pad, 0.0)
    } else {
        (2.0 * pad + 11.0 * ts, pad + 5.5 * ts)
    };
    let title_band = if fig.panels.iter().any(|p| !p.title.is_empty()) {
        lh + pad
    } else {
        0.0
    };
    let gap = 2.0 * pad;
    let mut bottom = tick + pad / 2.0 + lh + pad;
    if !fig.x_label.is_empty() {
        bottom += lh + pad / 2.0;
    }
    let n = fig.panels.len().max(1) as f64;
    let plot_h = ((h - top - bottom - n * title_band - (n - 1.0) * gap) / n)
        .floor()
        .max(1.0);

    let y_axes: Vec<Axis> = fig
        .panels
        .iter()
        .map(|p| {
            let r = min_max(p.series.iter().flat_map(finite_points).map(|(_, y)| y));
            Axis::fitted(axis_range(r, 0.05), plot_h, 1.8 * lh, None)
        })
        .collect();

    // Horizontal: y label, y tick labels, plot area, legend.
    let y_chars = y_axes.iter().map(Axis::max_label_chars).max().unwrap_or(0);
    let y_label_band = if fig.panels.iter().any(|p| !p.y_label.is_empty()) {
        lh + pad
    } else {
        0.0
    };
    let left = (pad + y_label_band + y_chars as f64 * cw + pad / 2.0 + tick).round();

    let legend_rows = (((plot_h - pad) / lh).floor() as usize).max(1);
    let max_chars = ((0.3 * w - 4.0 * cw) / cw).floor().max(4.0) as usize;
    let mut chars: Option<usize> = None;
    for p in &fig.panels {
        for s in &p.series {
            chars = Some(chars.unwrap_or(0).max(s.label.chars().count()));
        }
        if p.series.len() > legend_rows {
            let more = p.series.len() + 1 - legend_rows;
            chars = Some(chars.unwrap_or(0).max(more_text(more).len()));
        }
    }
    let (legend_w, legend_chars) = match chars {
        None => (0.0, 0),
        Some(c) => {
            let c = c.clamp(1, max_chars);
            (3.0 * pad + 2.5 * cw + c as f64 * cw, c)
        }
    };
    let right = if legend_w > 0.0 {
        3.0 * pad + legend_w
    } else {
        2.0 * pad
    };
    let plot_w = (w - left - right).floor().max(1.0);

    // The shared x axis: fewer ticks until their labels fit between them.
    let xr = axis_range(
        min_max(
            fig.panels
                .iter()
                .flat_map(|p| &p.series)
                .flat_map(finite_points)
                .map(|(x, _)| x),
        ),
        0.0,
    );
    let x_axis = Axis::fitted(xr, plot_w, 6.0 * cw, Some(cw));

    let panels = y_axes
        .into_iter()
        .enumerate()
        .map(|(i, a)| {
            let y = top + title_band + i as f64 * (plot_h + gap + title_band);
            (
                Rect {
                    x: left,
                    y: y.round(),
                    w: plot_w,
                    h: plot_h,
                },
                a,
            )
        })
        .collect();
    let last_bottom = (top + title_band + (n - 1.0) * (plot_h + gap + title_band)).round() + plot_h;
    Layout {
        w: wu,
        h: hu,
        s,
        cw,
        lh,
        pad,
        tick,
        lw: 0.75 * sf + 0.5,
        frame: (0.75 * sf).round().max(1.0),
        title_mid,
        x_axis,
        panels,
        y_label_x: pad + lh / 2.0,
        x_ticks_mid: last_bottom + tick + pad / 2.0 + lh / 2.0,
        x_label_mid: last_bottom + tick + pad + 1.5 * lh,
        legend_w,
        legend_chars,
        legend_rows,
    }
}

fn more_text(more: usize) -> String {
    format!("+{more} more")
}

/// `s` cut to `n` characters, the last two replaced by "..".
fn truncate(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_string()
    } else {
        s.chars().take(n.saturating_sub(2)).chain("..".chars()).collect()
    }
}

// ---------------------------------------------------------------------------------------------
// Drawing, shared by both outputs
// ---------------------------------------------------------------------------------------------

/// What both outputs can draw. Coordinates in pixels, y down.
trait Canvas {
    fn fill_rect(&mut self, r: Rect, c: Rgb);
    /// A frame of width `lw` inside `r`.
    fn stroke_rect(&mut self, r: Rect, lw: f64, c: Rgb);
    /// One polyline per run; a one-point run is a dot. Nothing is drawn outside `clip`.
    fn polylines(&mut self, runs: &[Vec<(f64, f64)>], lw: f64, c: Rgb, clip: Rect);
    /// `s` centred vertically on `y_mid` (horizontally on `x` for vertical text).
    fn text(&mut self, x: f64, y_mid: f64, s: &str, t: Text);
}

fn draw<C: Canvas>(fig: &Figure, l: &Layout, c: &mut C) {
    let (w, h) = (f64::from(l.w), f64::from(l.h));
    c.fill_rect(Rect { x: 0.0, y: 0.0, w, h }, WHITE);
    let normal = Text {
        size: l.s,
        anchor: Anchor::Middle,
        vertical: false,
        color: BLACK,
    };
    if !fig.title.is_empty() {
        c.text(
            w / 2.0,
            l.title_mid,
            &fig.title,
            Text {
                size: l.s + 1,
                ..normal
            },
        );
    }
    let f = l.frame;
    let last = fig.panels.len().saturating_sub(1);
    for (i, (p, (r, ya))) in fig.panels.iter().zip(&l.panels).enumerate() {
        let r = *r;
        let xs: Vec<f64> = l
            .x_axis
            .ticks
            .iter()
            .map(|&t| l.x_axis.map(t, r.x, r.x + r.w))
            .collect();
        let ys: Vec<f64> = ya.ticks.iter().map(|&t| ya.map(t, r.y + r.h, r.y)).collect();
        for &x in &xs {
            c.fill_rect(
                Rect {
                    x: (x - 0.5).round(),
                    y: r.y,
                    w: 1.0,
                    h: r.h,
                },
                GRID,
            );
        }
        for &y in &ys {
            c.fill_rect(
                Rect {
                    x: r.x,
                    y: (y - 0.5).round(),
                    w: r.w,
                    h: 1.0,
                },
                GRID,
            );
        }
        for stroke in [Stroke::Band, Stroke::Line] {
            for (k, s) in p.series.iter().enumerate().filter(|(_, s)| s.stroke == stroke) {
                let (lw, color) = pen(s, k, l.lw);
                c.polylines(&reduce(s, &l.x_axis, ya, r), lw, color, r);
            }
        }
        c.stroke_rect(r, f, BLACK);
        for (&y, label) in ys.iter().zip(&ya.labels) {
            c.fill_rect(
                Rect {
                    x: r.x - l.tick,
                    y: (y - f / 2.0).round(),
                    w: l.tick,
                    h: f,
                },
                BLACK,
            );
            let t = Text {
                anchor: Anchor::End,
                ..normal
            };
            c.text(r.x - l.tick - l.pad / 2.0, y, label, t);
        }
        for (&x, label) in xs.iter().zip(&l.x_axis.labels) {
            c.fill_rect(
                Rect {
                    x: (x - f / 2.0).round(),
                    y: r.y + r.h,
                    w: f,
                    h: l.tick,
                },
                BLACK,
            );
            if i == last {
                c.text(x, l.x_ticks_mid, label, normal);
            }
        }
        if !p.title.is_empty() {
            c.text(r.x + r.w / 2.0, r.y - l.pad / 2.0 - l.lh / 2.0, &p.title, normal);
        }
        if !p.y_label.is_empty() {
            c.text(
                l.y_label_x,
                r.y + r.h / 2.0,
                &p.y_label,
                Text {
                    vertical: true,
                    ..normal
                },
            );
        }
        legend(c, l, p, r);
    }
    if let Some((r, _)) = l.panels.last()
        && !fig.x_label.is_empty()
    {
        c.text(r.x + r.w / 2.0, l.x_label_mid, &fig.x_label, normal);
    }
}

/// The legend box right of plot area `r`: a colour bar and the label per series, as many as fit,
/// then "+N more".
fn legend<C: Canvas>(c: &mut C, l: &Layout, p: &Panel, r: Rect) {
    let n = p.series.len();
    if n == 0 {
        return;
    }
    let shown = if n <= l.legend_rows { n } else { l.legend_rows - 1 };
    let rows = if n <= l.legend_rows { n } else { l.legend_rows };
    let b = Rect {
        x: r.x + r.w + 2.0 * l.pad,
        y: r.y,
        w: l.legend_w,
        h: rows as f64 * l.lh + l.pad,
    };
    c.fill_rect(b, WHITE);
    c.stroke_rect(b, 1.0, LEGEND_EDGE);
    let t = Text {
        size: l.s,
        anchor: Anchor::Start,
        vertical: false,
        color: BLACK,
    };
    let text_x = b.x + 2.0 * l.pad + 2.5 * l.cw;
    let row_mid = |k: usize| b.y + l.pad / 2.0 + l.lh * (k as f64 + 0.5);
    for (k, s) in p.series.iter().take(shown).enumerate() {
        let y = row_mid(k);
        let (lw, color) = pen(s, k, l.lw);
        let bar = Rect {
            x: b.x + l.pad,
            y: (y - lw).round(),
            w: 2.5 * l.cw,
            h: (2.0 * lw).round(),
        };
        c.fill_rect(bar, color);
        c.text(text_x, y, &truncate(&s.label, l.legend_chars), t);
    }
    if shown < n {
        c.text(text_x, row_mid(shown), &more_text(n - shown), t);
    }
}

/// Line width and colour of series `s`, the `k`-th of its panel, for the figure's width `lw`.
fn pen(s: &Series, k: usize, lw: f64) -> (f64, Rgb) {
    let c = PALETTE[s.color.unwrap_or(k) % PALETTE.len()];
    match s.stroke {
        Stroke::Line => (lw, c),
        Stroke::Band => (4.0 * lw, tint(c)),
    }
}

/// The pale tint of `c` a band is drawn in.
fn tint(c: Rgb) -> Rgb {
    c.map(|v| 255 - ((255 - v) as f32 * 0.4).round() as u8)
}

/// First, lowest, highest and last point (in index order) of a run of points in one pixel column.
struct Column {
    col: i64,
    first: (usize, (f64, f64)),
    low: (usize, (f64, f64)),
    high: (usize, (f64, f64)),
    last: (usize, (f64, f64)),
}

impl Column {
    fn flush(self, run: &mut Vec<(f64, f64)>) {
        let mut pts = [self.first, self.low, self.high, self.last];
        pts.sort_by_key(|&(i, _)| i);
        let mut prev = None;
        for (i, p) in pts {
            if prev != Some(i) {
                run.push(p);
                prev = Some(i);
            }
        }
    }
}

/// `s` in pixel coordinates of plot area `r`, split into runs at non-finite points, with only
/// the first, lowest, highest and last point of each run of points in one pixel column.
fn reduce(s: &Series, xa: &Axis, ya: &Axis, r: Rect) -> Vec<Vec<(f64, f64)>> {
    fn end_run(col: &mut Option<Column>, run: &mut Vec<(f64, f64)>, runs: &mut Vec<Vec<(f64, f64)>>) {
        if let Some(c) = col.take() {
            c.flush(run);
        }
        if run.len() == 1 {
            run.push(run[0]);
        }
        if !run.is_empty() {
            runs.push(std::mem::take(run));
        }
    }
    let mut runs = Vec::new();
    let mut run = Vec::new();
    let mut col: Option<Column> = None;
    for (i, (&x, &y)) in s.x.iter().zip(&s.y).enumerate() {
        let p = (xa.map(x, r.x, r.x + r.w), ya.map(y, r.y + r.h, r.y));
        if !(x.is_finite() && y.is_finite() && p.0.is_finite() && p.1.is_finite()) {
            end_run(&mut col, &mut run, &mut runs);
            continue;
        }
        let k = p.0.floor() as i64;
        match &mut col {
            Some(c) if c.col == k => {
                if p.1 < c.low.1.1 {
                    c.low = (i, p);
                }
                if p.1 > c.high.1.1 {
                    c.high = (i, p);
                }
                c.last = (i, p);
            }
            _ => {
                if let Some(c) = col.take() {
                    c.flush(&mut run);
                }
                col = Some(Column {
                    col: k,
                    first: (i, p),
                    low: (i, p),
                    high: (i, p),
                    last: (i, p),
                });
            }
        }
    }
    end_run(&mut col, &mut run, &mut runs);
    runs
}

// ---------------------------------------------------------------------------------------------
// SVG
// ---------------------------------------------------------------------------------------------

#[derive(Default)]
struct SvgCanvas {
    out: String,
    /// The clip paths defined so far (`c0`, `c1`, …), the last one's rectangle.
    clips: usize,
    last_clip: Option<Rect>,
}

/// `v` with at most one decimal, no "-0".
fn push_num(out: &mut String, v: f64) {
    let r = (v * 10.0).round() / 10.0 + 0.0;
    if r.fract() == 0.0 {
        let _ = write!(out, "{r:.0}");
    } else {
        let _ = write!(out, "{r:.1}");
    }
}

fn push_color(out: &mut String, c: Rgb) {
    let _ = write!(out, "#{:02x}{:02x}{:02x}", c[0], c[1], c[2]);
}

/// `s` escaped for XML text and attributes; characters XML 1.0 forbids become '?'.
fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for ch in s.chars() {
        match ch {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            '\t' | '\n' | '\r' => out.push(' '),
            c if c < ' ' || c == '\u{fffe}' || c == '\u{ffff}' => out.push('?'),
            c => out.push(c),
        }
    }
    out
}

impl SvgCanvas {
    fn rect_attrs(&mut self, r: Rect) {
        self.out.push_str("<rect x=\"");
        push_num(&mut self.out, r.x);
        self.out.push_str("\" y=\"");
        push_num(&mut self.out, r.y);
        self.out.push_str("\" width=\"");
        push_num(&mut self.out, r.w.max(0.0));
        self.out.push_str("\" height=\"");
        push_num(&mut self.out, r.h.max(0.0));
        self.out.push('"');
    }
}

impl Canvas for SvgCanvas {
    fn fill_rect(&mut self, r: Rect, c: Rgb) {
        self.rect_attrs(r);
        self.out.push_str(" fill=\"");
        push_color(&mut self.out, c);
        self.out.push_str("\"/>\n");
    }

    fn stroke_rect(&mut self, r: Rect, lw: f64, c: Rgb) {
        let half = lw / 2.0;
        self.rect_attrs(Rect {
            x: r.x + half,
            y: r.y + half,
            w: r.w - lw,
            h: r.h - lw,
        });
        self.out.push_str(" fill=\"none\" stroke=\"");
        push_color(&mut self.out, c);
        self.out.push_str("\" stroke-width=\"");
        push_num(&mut self.out, lw);
        self.out.push_str("\"/>\n");
    }

    fn polylines(&mut self, runs: &[Vec<(f64, f64)>], lw: f64, c: Rgb, clip: Rect) {
        if self.last_clip != Some(clip) {
            let _ = write!(self.out, "<clipPath id=\"c{}\">", self.clips);
            self.rect_attrs(clip);
            self.out.push_str("/></clipPath>\n");
            self.clips += 1;
            self.last_clip = Some(clip);
        }
        for run in runs {
            let _ = write!(self.out, "<polyline clip-path=\"url(#c{})\"", self.clips - 1);
            self.out.push_str(" fill=\"none\" stroke=\"");
            push_color(&mut self.out, c);
            self.out.push_str("\" stroke-width=\"");
            push_num(&mut self.out, lw);
            self.out
                .push_str("\" stroke-linejoin=\"round\" stroke-linecap=\"round\" points=\"");
            for (k, &(x, y)) in run.iter().enumerate() {
                if k > 0 {
                    self.out.push(' ');
                }
                push_num(&mut self.out, x);
                self.out.push(',');
                push_num(&mut self.out, y);
            }
            self.out.push_str("\"/>\n");
        }
    }

    fn text(&mut self, x: f64, y_mid: f64, s: &str, t: Text) {
        let anchor = match t.anchor {
            Anchor::Start => "start",
            Anchor::Middle => "middle",
            Anchor::End => "end",
        };
        self.out.push_str("<text x=\"");
        push_num(&mut self.out, x);
        self.out.push_str("\" y=\"");
        push_num(&mut self.out, y_mid);
        let _ = write!(
            self.out,
            "\" dy=\"0.35em\" font-size=\"{}\" text-anchor=\"{anchor}\"",
            10 * t.size
        );
        if t.vertical {
            self.out.push_str(" transform=\"rotate(-90 ");
            push_num(&mut self.out, x);
            self.out.push(' ');
            push_num(&mut self.out, y_mid);
            self.out.push_str(")\"");
        }
        self.out.push_str(" fill=\"");
        push_color(&mut self.out, t.color);
        self.out.push_str("\">");
        self.out.push_str(&escape(s));
        self.out.push_str("</text>\n");
    }
}

// ---------------------------------------------------------------------------------------------
// Raster
// ---------------------------------------------------------------------------------------------

/// An RGB image, rows top to bottom, and the coverage mask a polyline is drawn into before it is
/// blended in (so joints are not painted twice).
struct Raster {
    w: usize,
    h: usize,
    rgb: Vec<u8>,
    mask: Vec<f32>,
}

fn render(fig: &Figure, width: u32, height: u32) -> Raster {
    let l = layout(fig, width, height);
    let (w, h) = (l.w as usize, l.h as usize);
    let mut r = Raster {
        w,
        h,
        rgb: vec![255; w * h * 3],
        mask: vec![0.0; w * h],
    };
    draw(fig, &l, &mut r);
    r
}

/// The pixel range covering `[start, start + len)`, at least one pixel wide, clipped to
/// `[0, max)`.
fn pixel_span(start: f64, len: f64, max: usize) -> (usize, usize) {
    if !(start.is_finite() && len.is_finite()) || len <= 0.0 {
        return (0, 0);
    }
    let a = start.round();
    let b = (start + len).round().max(a + 1.0);
    let clip = |v: f64| v.clamp(0.0, max as f64) as usize;
    (clip(a), clip(b))
}

/// Distance from `(px, py)` to the segment `a`–`b`.
fn segment_distance(px: f64, py: f64, a: (f64, f64), b: (f64, f64)) -> f64 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let l2 = dx * dx + dy * dy;
    let t = if l2 > 0.0 {
        (((px - a.0) * dx + (py - a.1) * dy) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let (ex, ey) = (px - (a.0 + t * dx), py - (a.1 + t * dy));
    // Pixel coordinates: no overflow for `hypot` to guard against, at a tenth of its cost.
    (ex * ex + ey * ey).sqrt()
}

/// Pixel bounds touched in the mask: x0, y0, x1, y1 (inclusive), empty when x0 > x1.
type Bounds = (usize, usize, usize, usize);

impl Raster {
    /// Adds the segment `a`–`b`, `2 hw` wide with round caps, to the mask: each pixel's coverage
    /// falls linearly over the last pixel of the line's edge. Visits only pixels near the line.
    fn segment_to_mask(&mut self, a: (f64, f64), b: (f64, f64), hw: f64, bb: &mut Bounds) {
        let reach = hw + 1.0;
        let steep = (b.1 - a.1).abs() > (b.0 - a.0).abs();
        // (u, v): major and minor axis.
        let (au, av, bu, bv) = if steep {
            (a.1, a.0, b.1, b.0)
        } else {
            (a.0, a.1, b.0, b.1)
        };
        let (umax, vmax) = if steep { (self.h, self.w) } else { (self.w, self.h) };
        let clip = |v: f64, max: usize| v.clamp(0.0, max as f64 - 1.0) as usize;
        let u0 = clip((au.min(bu) - reach).floor(), umax);
        let u1 = clip((au.max(bu) + reach).floor(), umax);
        let du = bu - au;
        for iu in u0..=u1 {
            let (v_lo, v_hi) = if du.abs() < 1e-12 {
                (av.min(bv), av.max(bv))
            } else {
                let t0 = ((iu as f64 - reach - au) / du).clamp(0.0, 1.0);
                let t1 = ((iu as f64 + 1.0 + reach - au) / du).clamp(0.0, 1.0);
                let (v0, v1) = (av + (bv - av) * t0, av + (bv - av) * t1);
                (v0.min(v1), v0.max(v1))
            };
            let v0 = clip((v_lo - reach).floor(), vmax);
            let v1 = clip((v_hi + reach).floor(), vmax);
            for iv in v0..=v1 {
                let (x, y) = if steep { (iv, iu) } else { (iu, iv) };
                let d = segment_distance(x as f64 + 0.5, y as f64 + 0.5, a, b);
                let cov = (hw + 0.5 - d).clamp(0.0, 1.0) as f32;
                if cov > 0.0 {
                    let m = &mut self.mask[y * self.w + x];
                    *m = m.max(cov);
                    *bb = (bb.0.min(x), bb.1.min(y), bb.2.max(x), bb.3.max(y));
                }
            }
        }
    }
}

impl Canvas for Raster {
    fn fill_rect(&mut self, r: Rect, c: Rgb) {
        let (x0, x1) = pixel_span(r.x, r.w, self.w);
        let (y0, y1) = pixel_span(r.y, r.h, self.h);
        for y in y0..y1 {
            let row = &mut self.rgb[(y * self.w + x0) * 3..(y * self.w + x1) * 3];
            for px in row.chunks_exact_mut(3) {
                px.copy_from_slice(&c);
            }
        }
    }

    fn stroke_rect(&mut self, r: Rect, lw: f64, c: Rgb) {
        let f = lw.round().max(1.0);
        self.fill_rect(Rect { h: f, ..r }, c);
        self.fill_rect(
            Rect {
                y: r.y + r.h - f,
                h: f,
                ..r
            },
            c,
        );
        self.fill_rect(Rect { w: f, ..r }, c);
        self.fill_rect(
            Rect {
                x: r.x + r.w - f,
                w: f,
                ..r
            },
            c,
        );
    }

    fn polylines(&mut self, runs: &[Vec<(f64, f64)>], lw: f64, c: Rgb, clip: Rect) {
        let mut bb: Bounds = (usize::MAX, usize::MAX, 0, 0);
        for run in runs {
            for pair in run.windows(2) {
                self.segment_to_mask(pair[0], pair[1], lw / 2.0, &mut bb);
            }
        }
        if bb.0 > bb.2 {
            return;
        }
        let (cx, cy) = (
            pixel_span(clip.x, clip.w, self.w),
            pixel_span(clip.y, clip.h, self.h),
        );
        for y in bb.1..=bb.3 {
            for x in bb.0..=bb.2 {
                let i = y * self.w + x;
                let a = self.mask[i];
                self.mask[i] = 0.0;
                if a > 0.0 && (cx.0..cx.1).contains(&x) && (cy.0..cy.1).contains(&y) {
                    for (ch, &cc) in self.rgb[i * 3..i * 3 + 3].iter_mut().zip(&c) {
                        *ch = (f32::from(*ch) * (1.0 - a) + f32::from(cc) * a).round() as u8;
                    }
                }
            }
        }
    }

    fn text(&mut self, x: f64, y_mid: f64, s: &str, t: Text) {
        let sc = f64::from(t.size);
        let len = (s.chars().count() as f64 * 6.0 - 1.0).max(0.0) * sc;
        let off = match t.anchor {
            Anchor::Start => 0.0,
            Anchor::Middle => len / 2.0,
            Anchor::End => len,
        };
        // Along the text and across it (down the glyph), from the glyph's top-left.
        let (along0, across0) = if t.vertical {
            ((y_mid + off).round(), (x - 3.5 * sc).round())
        } else {
            ((x - off).round(), (y_mid - 3.5 * sc).round())
        };
        for (i, ch) in s.chars().enumerate() {
            for (col, bits) in glyph(ch).iter().enumerate() {
                for row in 0..7 {
                    if (bits >> row) & 1 == 0 {
                        continue;
                    }
                    let along = (i * 6 + col) as f64 * sc;
                    let across = across0 + f64::from(row) * sc;
                    let r = if t.vertical {
                        Rect {
                            x: across,
                            y: along0 - along - sc,
                            w: sc,
                            h: sc,
                        }
                    } else {
                        Rect {
                            x: along0 + along,
                            y: across,
                            w: sc,
                            h: sc,
                        }
                    };
                    self.fill_rect(r, t.color);
                }
            }
        }
    }
}

/// 5×7 glyphs for ASCII 32..=126: five columns left to right, bit 0 the top row.
const FONT: [[u8; 5]; 95] = [
    [0x00, 0x00, 0x00, 0x00, 0x00], // ' '
    [0x00, 0x00, 0x5F, 0x00, 0x00], // '!'
    [0x00, 0x07, 0x00, 0x07, 0x00], // '"'
    [0x14, 0x7F, 0x14, 0x7F, 0x14], // '#'
    [0x24, 0x2A, 0x7F, 0x2A, 0x12], // '$'
    [0x23, 0x13, 0x08, 0x64, 0x62], // '%'
    [0x36, 0x49, 0x55, 0x22, 0x50], // '&'
    [0x00, 0x05, 0x03, 0x00, 0x00], // '\''
    [0x00, 0x1C, 0x22, 0x41, 0x00], // '('
    [0x00, 0x41, 0x22, 0x1C, 0x00], // ')'
    [0x14, 0x08, 0x3E, 0x08, 0x14], // '*'
    [0x08, 0x08, 0x3E, 0x08, 0x08], // '+'
    [0x00, 0x50, 0x30, 0x00, 0x00], // ','
    [0x08, 0x08, 0x08, 0x08, 0x08], // '-'
    [0x00, 0x60, 0x60, 0x00, 0x00], // '.'
    [0x20, 0x10, 0x08, 0x04, 0x02], // '/'
    [0x3E, 0x51, 0x49, 0x45, 0x3E], // '0'
    [0x00, 0x42, 0x7F, 0x40, 0x00], // '1'
    [0x42, 0x61, 0x51, 0x49, 0x46], // '2'
    [0x21, 0x41, 0x45, 0x4B, 0x31], // '3'
    [0x18, 0x14, 0x12, 0x7F, 0x10], // '4'
    [0x27, 0x45, 0x45, 0x45, 0x39], // '5'
    [0x3C, 0x4A, 0x49, 0x49, 0x30], // '6'
    [0x01, 0x71, 0x09, 0x05, 0x03], // '7'
    [0x36, 0x49, 0x49, 0x49, 0x36], // '8'
    [0x06, 0x49, 0x49, 0x29, 0x1E], // '9'
    [0x00, 0x36, 0x36, 0x00, 0x00], // ':'
    [0x00, 0x56, 0x36, 0x00, 0x00], // ';'
    [0x08, 0x14, 0x22, 0x41, 0x00], // '<'
    [0x14, 0x14, 0x14, 0x14, 0x14], // '='
    [0x00, 0x41, 0x22, 0x14, 0x08], // '>'
    [0x02, 0x01, 0x51, 0x09, 0x06], // '?'
    [0x32, 0x49, 0x79, 0x41, 0x3E], // '@'
    [0x7E, 0x11, 0x11, 0x11, 0x7E], // 'A'
    [0x7F, 0x49, 0x49, 0x49, 0x36], // 'B'
    [0x3E, 0x41, 0x41, 0x41, 0x22], // 'C'
    [0x7F, 0x41, 0x41, 0x22, 0x1C], // 'D'
    [0x7F, 0x49, 0x49, 0x49, 0x41], // 'E'
    [0x7F, 0x09, 0x09, 0x09, 0x01], // 'F'
    [0x3E, 0x41, 0x49, 0x49, 0x7A], // 'G'
    [0x7F, 0x08, 0x08, 0x08, 0x7F], // 'H'
    [0x00, 0x41, 0x7F, 0x41, 0x00], // 'I'
    [0x20, 0x40, 0x41, 0x3F, 0x01], // 'J'
    [0x7F, 0x08, 0x14, 0x22, 0x41], // 'K'
    [0x7F, 0x40, 0x40, 0x40, 0x40], // 'L'
    [0x7F, 0x02, 0x0C, 0x02, 0x7F], // 'M'
    [0x7F, 0x04, 0x08, 0x10, 0x7F], // 'N'
    [0x3E, 0x41, 0x41, 0x41, 0x3E], // 'O'
    [0x7F, 0x09, 0x09, 0x09, 0x06], // 'P'
    [0x3E, 0x41, 0x51, 0x21, 0x5E], // 'Q'
    [0x7F, 0x09, 0x19, 0x29, 0x46], // 'R'
    [0x46, 0x49, 0x49, 0x49, 0x31], // 'S'
    [0x01, 0x01, 0x7F, 0x01, 0x01], // 'T'
    [0x3F, 0x40, 0x40, 0x40, 0x3F], // 'U'
    [0x1F, 0x20, 0x40, 0x20, 0x1F], // 'V'
    [0x3F, 0x40, 0x38, 0x40, 0x3F], // 'W'
    [0x63, 0x14, 0x08, 0x14, 0x63], // 'X'
    [0x07, 0x08, 0x70, 0x08, 0x07], // 'Y'
    [0x61, 0x51, 0x49, 0x45, 0x43], // 'Z'
    [0x00, 0x7F, 0x41, 0x41, 0x00], // '['
    [0x02, 0x04, 0x08, 0x10, 0x20], // '\\'
    [0x00, 0x41, 0x41, 0x7F, 0x00], // ']'
    [0x04, 0x02, 0x01, 0x02, 0x04], // '^'
    [0x40, 0x40, 0x40, 0x40, 0x40], // '_'
    [0x00, 0x01, 0x02, 0x04, 0x00], // '`'
    [0x20, 0x54, 0x54, 0x54, 0x78], // 'a'
    [0x7F, 0x48, 0x44, 0x44, 0x38], // 'b'
    [0x38, 0x44, 0x44, 0x44, 0x20], // 'c'
    [0x38, 0x44, 0x44, 0x48, 0x7F], // 'd'
    [0x38, 0x54, 0x54, 0x54, 0x18], // 'e'
    [0x08, 0x7E, 0x09, 0x01, 0x02], // 'f'
    [0x08, 0x54, 0x54, 0x54, 0x3C], // 'g'
    [0x7F, 0x08, 0x04, 0x04, 0x78], // 'h'
    [0x00, 0x44, 0x7D, 0x40, 0x00], // 'i'
    [0x20, 0x40, 0x44, 0x3D, 0x00], // 'j'
    [0x7F, 0x10, 0x28, 0x44, 0x00], // 'k'
    [0x00, 0x41, 0x7F, 0x40, 0x00], // 'l'
    [0x7C, 0x04, 0x18, 0x04, 0x78], // 'm'
    [0x7C, 0x08, 0x04, 0x04, 0x78], // 'n'
    [0x38, 0x44, 0x44, 0x44, 0x38], // 'o'
    [0x7C, 0x14, 0x14, 0x14, 0x08], // 'p'
    [0x08, 0x14, 0x14, 0x14, 0x7C], // 'q'
    [0x7C, 0x08, 0x04, 0x04, 0x08], // 'r'
    [0x48, 0x54, 0x54, 0x54, 0x20], // 's'
    [0x04, 0x3F, 0x44, 0x40, 0x20], // 't'
    [0x3C, 0x40, 0x40, 0x20, 0x7C], // 'u'
    [0x1C, 0x20, 0x40, 0x20, 0x1C], // 'v'
    [0x3C, 0x40, 0x30, 0x40, 0x3C], // 'w'
    [0x44, 0x28, 0x10, 0x28, 0x44], // 'x'
    [0x0C, 0x50, 0x50, 0x50, 0x3C], // 'y'
    [0x44, 0x64, 0x54, 0x4C, 0x44], // 'z'
    [0x00, 0x08, 0x36, 0x41, 0x00], // '{'
    [0x00, 0x00, 0x7F, 0x00, 0x00], // '|'
    [0x00, 0x41, 0x36, 0x08, 0x00], // '}'
    [0x08, 0x04, 0x08, 0x10, 0x08], // '~'
];

/// The glyph of `ch`; '?' outside printable ASCII.
fn glyph(ch: char) -> &'static [u8; 5] {
    let i = u32::from(ch);
    let i = if (32..=126).contains(&i) {
        i
    } else {
        u32::from('?')
    };
    &FONT[(i - 32) as usize]
}

// ---------------------------------------------------------------------------------------------
// PNG encoding
// ---------------------------------------------------------------------------------------------

const CRC_TABLE: [u32; 256] = {
    let mut t = [0u32; 256];
    let mut n = 0;
    while n < 256 {
        let mut c = n as u32;
        let mut k = 0;
        while k < 8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
            k += 1;
        }
        t[n] = c;
        n += 1;
    }
    t
};

/// The running CRC-32 register (start with `!0`, finish with `!`).
fn crc32_update(mut crc: u32, data: &[u8]) -> u32 {
    for &b in data {
        crc = CRC_TABLE[((crc ^ u32::from(b)) & 0xff) as usize] ^ (crc >> 8);
    }
    crc
}

/// CRC-32 (ISO-HDLC, as in PNG and zlib's `crc32`).
#[cfg(test)]
fn crc32(data: &[u8]) -> u32 {
    !crc32_update(!0, data)
}

/// Adler-32, zlib's checksum.
fn adler32(data: &[u8]) -> u32 {
    const MOD: u32 = 65_521;
    let (mut a, mut b) = (1u32, 0u32);
    // 5552 bytes is the most that cannot overflow `b` before the reduction.
    for block in data.chunks(5552) {
        for &x in block {
            a += u32::from(x);
            b += a;
        }
        a %= MOD;
        b %= MOD;
    }
    (b << 16) | a
}

fn png_chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    out.extend_from_slice(&(data.len() as u32).to_be_bytes());
    out.extend_from_slice(kind);
    out.extend_from_slice(data);
    out.extend_from_slice(&(!crc32_update(crc32_update(!0, kind), data)).to_be_bytes());
}

/// `rgb` (`w` × `h`, rows top to bottom) as a PNG: filter 0 (None) on every row, one IDAT holding
/// a zlib stream of one [`deflate`] block whose matches also look one row up.
///
/// Filters 1 (Sub) and 2 (Up), alone or chosen per row by the minimum sum of absolute
/// differences, made a four-panel 1200 × 900 figure 4 to 25 % larger: a curve crossing a row
/// turns into differences both where it is and where it was in the row above, and the
/// anti-aliased profiles of the lines repeat (and so match) only unfiltered.
fn encode_png(w: usize, h: usize, rgb: &[u8]) -> Vec<u8> {
    let row = w * 3;
    let mut raw = Vec::with_capacity((row + 1) * h);
    for line in rgb.chunks_exact(row) {
        raw.push(0);
        raw.extend_from_slice(line);
    }
    let z = zlib(&raw, row + 1);
    let mut ihdr = [0u8; 13];
    ihdr[0..4].copy_from_slice(&(w as u32).to_be_bytes());
    ihdr[4..8].copy_from_slice(&(h as u32).to_be_bytes());
    // Bit depth 8, colour type 2 (RGB), compression 0, filter method 0, no interlace.
    ihdr[8..13].copy_from_slice(&[8, 2, 0, 0, 0]);
    let mut out = Vec::with_capacity(z.len() + 64);
    out.extend_from_slice(&[0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1A, b'\n']);
    png_chunk(&mut out, b"IHDR", &ihdr);
    png_chunk(&mut out, b"IDAT", &z);
    png_chunk(&mut out, b"IEND", &[]);
    out
}

/// `data` as a zlib stream (RFC 1950) of one [`deflate`] block; `row` as there.
fn zlib(data: &[u8], row: usize) -> Vec<u8> {
    // CMF: deflate, 32 KiB window; FLG: no dictionary, check bits making 0x7801 a multiple of 31.
    let mut z = vec![0x78, 0x01];
    z.extend_from_slice(&deflate(data, row));
    z.extend_from_slice(&adler32(data).to_be_bytes());
    z
}

// ---------------------------------------------------------------------------------------------
// Deflate (RFC 1951): LZ77 matches over a 32 KiB window, fixed Huffman codes
// ---------------------------------------------------------------------------------------------

const WINDOW: usize = 1 << 15;
const MIN_MATCH: usize = 3;
const MAX_MATCH: usize = 258;
const HASH_BITS: u32 = 15;
/// Candidates examined per position: the cap that keeps long runs of one byte linear.
const MAX_CHAIN: usize = 32;
/// Empty slot in the hash chains.
const NONE: u32 = u32::MAX;
/// Length codes 257..=285: shortest length and extra bits (§3.2.5).
const LEN_BASE: [u16; 29] = [
    3, 4, 5, 6, 7, 8, 9, 10, 11, 13, 15, 17, 19, 23, 27, 31, 35, 43, 51, 59, 67, 83, 99, 115, 131, 163, 195,
    227, 258,
];
const LEN_EXTRA: [u8; 29] = [
    0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0,
];
/// Distance codes 0..=29: shortest distance and extra bits.
const DIST_BASE: [u16; 30] = [
    1, 2, 3, 4, 5, 7, 9, 13, 17, 25, 33, 49, 65, 97, 129, 193, 257, 385, 513, 769, 1025, 1537, 2049, 3073,
    4097, 6145, 8193, 12289, 16385, 24577,
];
const DIST_EXTRA: [u8; 30] = [
    0, 0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12, 12, 13, 13,
];

/// `data` as a raw deflate stream: one final block with the fixed Huffman codes (BTYPE 01), of
/// literals and of the longest match among the last [`MAX_CHAIN`] earlier positions with the same
/// 3-byte hash and the position `row` bytes back (image rows; 0 or more than the window: none),
/// taken lazily (a literal first when the match at the next byte is longer). Deterministic.
fn deflate(data: &[u8], row: usize) -> Vec<u8> {
    let mut out = BitWriter::default();
    out.put(0b011, 3); // BFINAL = 1, BTYPE = 01.
    let mut m = Matcher {
        head: vec![NONE; 1 << HASH_BITS],
        prev: vec![NONE; WINDOW],
        row,
    };
    let mut i = 0;
    let mut here = m.find(data, 0);
    while i < data.len() {
        m.insert(data, i);
        let next = m.find(data, i + 1);
        if here.0 < MIN_MATCH || next.0 > here.0 {
            out.symbol(u16::from(data[i]));
            (i, here) = (i + 1, next);
            continue;
        }
        out.copy(here.0, here.1);
        for j in i + 1..i + here.0 {
            m.insert(data, j);
        }
        i += here.0;
        here = m.find(data, i);
    }
    out.symbol(256);
    out.finish()
}

/// Hash chains: `head[h]` is the latest position whose next 3 bytes hash to `h`, `prev[p % WINDOW]`
/// the one before `p` with the same hash.
struct Matcher {
    head: Vec<u32>,
    prev: Vec<u32>,
    row: usize,
}

impl Matcher {
    fn hash(data: &[u8], i: usize) -> usize {
        let v = u32::from_le_bytes([data[i], data[i + 1], data[i + 2], 0]);
        (v.wrapping_mul(0x9E37_79B1) >> (32 - HASH_BITS)) as usize
    }

    fn insert(&mut self, data: &[u8], i: usize) {
        if i + MIN_MATCH <= data.len() {
            let h = Self::hash(data, i);
            self.prev[i % WINDOW] = self.head[h];
            self.head[h] = i as u32;
        }
    }

    /// The longest match `(length, distance)` for `data[i..]` among the chained positions
    /// (inserted up to `i - 1`), or `(0, 0)` if none reaches [`MIN_MATCH`].
    fn find(&self, data: &[u8], i: usize) -> (usize, usize) {
        let max = data.len().saturating_sub(i).min(MAX_MATCH);
        if max < MIN_MATCH {
            return (0, 0);
        }
        let mut best = (0, 0);
        // Whether `c` gives a longer match; true once no longer one is possible.
        let mut longer = |c: usize| {
            let probe = best.0.min(max - 1);
            if data[c + probe] == data[i + probe] {
                let same = data[c..c + max].iter().zip(&data[i..i + max]);
                let len = same.take_while(|(a, b)| a == b).count();
                if len > best.0 {
                    best = (len, i - c);
                }
            }
            best.0 == max
        };
        let mut cand = self.head[Self::hash(data, i)];
        for _ in 0..MAX_CHAIN {
            // Positions come newest first; a slot older than the window may have been reused.
            if cand == NONE || i - cand as usize > WINDOW {
                break;
            }
            if longer(cand as usize) {
                break;
            }
            cand = self.prev[cand as usize % WINDOW];
        }
        // Last, so that a tie goes to the nearer match: the same column one row up, which the
        // chain rarely reaches past the positions of the white runs in between.
        if (1..=WINDOW).contains(&self.row) && i >= self.row {
            longer(i - self.row);
        }
        if best.0 >= MIN_MATCH { best } else { (0, 0) }
    }
}

/// Bits packed least significant first, as deflate stores them.
#[derive(Default)]
struct BitWriter {
    out: Vec<u8>,
    acc: u64,
    n: u32,
}

impl BitWriter {
    /// The low `n` bits of `v`, least significant first (extra bits, headers).
    fn put(&mut self, v: u32, n: u32) {
        self.acc |= u64::from(v) << self.n;
        self.n += n;
        while self.n >= 8 {
            self.out.push(self.acc as u8);
            (self.acc, self.n) = (self.acc >> 8, self.n - 8);
        }
    }

    /// An `n`-bit Huffman code, which deflate stores most significant bit first.
    fn code(&mut self, code: u32, n: u32) {
        self.put(code.reverse_bits() >> (32 - n), n);
    }

    /// Literal/length symbol `s` (0..=287) in the fixed code of §3.2.6.
    fn symbol(&mut self, s: u16) {
        let s = u32::from(s);
        match s {
            0..=143 => self.code(0x30 + s, 8),
            144..=255 => self.code(0x190 + s - 144, 9),
            256..=279 => self.code(s - 256, 7),
            _ => self.code(0xC0 + s - 280, 8),
        }
    }

    /// A back-reference: `len` (3..=258) bytes from `dist` (1..=32768) bytes back.
    fn copy(&mut self, len: usize, dist: usize) {
        let l = LEN_BASE.partition_point(|&b| usize::from(b) <= len) - 1;
        self.symbol(257 + l as u16);
        self.put((len - usize::from(LEN_BASE[l])) as u32, u32::from(LEN_EXTRA[l]));
        let d = DIST_BASE.partition_point(|&b| usize::from(b) <= dist) - 1;
        self.code(d as u32, 5);
        self.put(
            (dist - usize::from(DIST_BASE[d])) as u32,
            u32::from(DIST_EXTRA[d]),
        );
    }

    /// The bytes, the last one padded with zeros.
    fn finish(mut self) -> Vec<u8> {
        if self.n > 0 {
            self.out.push(self.acc as u8);
        }
        self.out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(label: &str, x: Vec<f64>, y: Vec<f64>) -> Series {
        Series {
            label: label.to_string(),
            x,
            y,
            ..Series::default()
        }
    }

    fn line_figure() -> Figure {
        Figure {
            title: "Line".into(),
            x_label: "t, s".into(),
            panels: vec![Panel {
                title: "y = x".into(),
                y_label: "y".into(),
                series: vec![series("y", vec![0.0, 1.0], vec![0.0, 1.0])],
            }],
        }
    }

    fn decode(bytes: &[u8]) -> (png::OutputInfo, Vec<u8>) {
        let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        let mut reader = decoder.read_info().expect("PNG header");
        let mut buf = vec![0; reader.output_buffer_size().expect("buffer size")];
        let info = reader.next_frame(&mut buf).expect("PNG frame");
        buf.truncate(info.buffer_size());
        (info, buf)
    }

    #[test]
    fn checksums_match_the_reference_values() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(crc32(b""), 0);
        assert_eq!(adler32(b"Wikipedia"), 0x11E6_0398);
        assert_eq!(adler32(b""), 1);
        // Long input: past the 5552-byte reduction blocks.
        let data: Vec<u8> = (0..100_000u32).map(|i| (i * 7 % 251) as u8).collect();
        let (mut a, mut b) = (1u64, 0u64);
        for &x in &data {
            a = (a + u64::from(x)) % 65_521;
            b = (b + a) % 65_521;
        }
        assert_eq!(adler32(&data), ((b << 16) | a) as u32);
    }

    #[test]
    fn png_decodes_with_lines_where_drawn_and_white_elsewhere() {
        let fig = line_figure();
        let bytes = to_png(&fig, 800, 600);
        let (info, buf) = decode(&bytes);
        assert_eq!((info.width, info.height), (800, 600));
        assert_eq!(info.color_type, png::ColorType::Rgb);
        assert_eq!(info.bit_depth, png::BitDepth::Eight);
        // The decoder sees exactly the rasterised pixels.
        assert_eq!(buf, render(&fig, 800, 600).rgb);
        let pixel = |x: f64, y: f64| {
            let i = (y as usize * 800 + x as usize) * 3;
            [buf[i], buf[i + 1], buf[i + 2]]
        };

        let l = layout(&fig, 800, 600);
        let (r, ya) = &l.panels[0];
        let at = |x: f64, y: f64| (l.x_axis.map(x, r.x, r.x + r.w), ya.map(y, r.y + r.h, r.y));
        // On the line: the palette's first colour.
        let (px, py) = at(0.5, 0.5);
        let bluest = (0..9)
            .map(|k| pixel(px - 1.0 + (k % 3) as f64, py - 1.0 + (k / 3) as f64))
            .max_by_key(|c| i32::from(c[2]) - i32::from(c[0]))
            .unwrap();
        assert!(bluest[2] > bluest[0] + 100, "line pixel {bluest:?}");
        // Between grid lines, away from the line: white.
        let xt = &l.x_axis.ticks;
        let (px, py) = at(
            (xt[xt.len() - 2] + xt[xt.len() - 1]) / 2.0,
            (ya.ticks[0] + ya.ticks[1]) / 2.0,
        );
        assert_eq!(pixel(px, py), WHITE);
        // The frame is black; the margin right of it, below the legend, white.
        assert_eq!(pixel(r.x, r.y + r.h / 2.0), BLACK);
        assert_eq!(pixel(r.x + r.w + 2.0, r.y + r.h - 2.0), WHITE);
    }

    #[test]
    fn a_band_lies_under_the_line_of_its_colour_whatever_the_order() {
        // The line listed first, its reference band second, both in palette colour 3.
        let shade = |stroke| Series {
            color: Some(3),
            stroke,
            ..series("s", vec![0.0, 1.0], vec![0.5, 0.5])
        };
        let fig = Figure {
            panels: vec![Panel {
                series: vec![shade(Stroke::Line), shade(Stroke::Band)],
                ..Panel::default()
            }],
            ..Figure::default()
        };
        let l = layout(&fig, 1200, 900);
        let (r, ya) = &l.panels[0];
        let xt = &l.x_axis.ticks;
        let px = l.x_axis.map((xt[0] + xt[1]) / 2.0, r.x, r.x + r.w);
        let py = ya.map(0.5, r.y + r.h, r.y);
        let raster = render(&fig, 1200, 900);
        let pixel = |dy: f64| {
            let i = (((py + dy).floor() as usize) * 1200 + px as usize) * 3;
            [raster.rgb[i], raster.rgb[i + 1], raster.rgb[i + 2]]
        };
        let line = PALETTE[3];
        let tint = tint(line);
        // On the line its full colour (the band did not paint over it); beside it, within the
        // band's half width of 2 line widths, the tint; past the band, white.
        assert_eq!(pixel(0.0), line);
        for side in [-1.0, 1.0] {
            let column: Vec<Rgb> = (1..=6).map(|d| pixel(side * f64::from(d))).collect();
            assert!(column.contains(&tint), "{column:?}");
            assert_eq!(pixel(side * 3.0 * l.lw), WHITE);
        }
        // The band ends at the plot area's right edge: its round cap is clipped at the frame.
        let beyond = ((py.floor() as usize) * 1200 + (r.x + r.w + 1.5) as usize) * 3;
        assert_eq!(raster.rgb[beyond..beyond + 3], WHITE);
        // The SVG draws the band first, four times as wide, in the tint, clipped alike.
        let svg = to_svg(&fig, 1200, 900);
        let polylines: Vec<&str> = svg.lines().filter(|s| s.starts_with("<polyline")).collect();
        let pen = |c: Rgb, w: f64| {
            let mut s = String::from("stroke=\"");
            push_color(&mut s, c);
            s.push_str("\" stroke-width=\"");
            push_num(&mut s, w);
            s
        };
        assert_eq!(polylines.len(), 2);
        let mut area = SvgCanvas::default();
        area.rect_attrs(*r);
        let clip = format!("<clipPath id=\"c0\">{}/></clipPath>", area.out);
        assert!(svg.contains(&clip), "{clip}");
        assert!(
            polylines
                .iter()
                .all(|p| p.starts_with("<polyline clip-path=\"url(#c0)\""))
        );
        assert!(polylines[0].contains(&pen(tint, 4.0 * l.lw)), "{}", polylines[0]);
        assert!(polylines[1].contains(&pen(line, l.lw)), "{}", polylines[1]);
    }

    #[test]
    fn png_is_well_formed_at_odd_and_clamped_sizes() {
        let fig = line_figure();
        for (w, h, ew, eh) in [(333, 217, 333, 217), (1, 1, 64, 64), (1500, 70, 1500, 70)] {
            let (info, _) = decode(&to_png(&fig, w, h));
            assert_eq!((info.width, info.height), (ew, eh));
        }
        // Signature, then IHDR first and IEND last.
        let bytes = to_png(&fig, 100, 100);
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        assert_eq!(&bytes[12..16], b"IHDR");
        assert_eq!(&bytes[bytes.len() - 8..bytes.len() - 4], b"IEND");
    }

    #[test]
    fn svg_has_one_polyline_per_series_and_escapes_text() {
        let fig = Figure {
            title: "Moments & forces".into(),
            x_label: "t, s".into(),
            panels: vec![
                Panel {
                    title: "a<&>b".into(),
                    y_label: "M, N m".into(),
                    series: vec![
                        series("a<&>b", vec![0.0, 1.0, 2.0], vec![1.0, -1.0, 0.5]),
                        series("q2", vec![0.0, 1.0, 2.0], vec![0.0, 0.2, 0.1]),
                    ],
                },
                Panel {
                    title: String::new(),
                    y_label: String::new(),
                    series: vec![series("F_x", vec![0.0, 2.0], vec![3.0, 4.0])],
                },
            ],
        };
        let svg = to_svg(&fig, 900, 700);
        assert!(svg.starts_with("<?xml"));
        assert!(svg.trim_end().ends_with("</svg>"));
        assert_eq!(svg.matches("<polyline").count(), 3);
        assert!(svg.contains("a&lt;&amp;&gt;b"));
        assert!(svg.contains("Moments &amp; forces"));
        assert!(!svg.contains("a<&>b"));
        // Every '&' starts an entity.
        for (i, _) in svg.match_indices('&') {
            let rest = &svg[i..];
            assert!(
                ["&amp;", "&lt;", "&gt;", "&quot;", "&apos;"]
                    .iter()
                    .any(|e| rest.starts_with(e))
            );
        }
        // Tags balance.
        assert_eq!(svg.matches("<text").count(), svg.matches("</text>").count());
        assert_eq!(escape("x\u{1}\"y'"), "x?&quot;y&apos;");
    }

    #[test]
    fn nice_ticks() {
        assert_eq!(Axis::new((0.0, 7.3), 5).ticks, vec![0.0, 2.0, 4.0, 6.0]);
        assert_eq!(
            Axis::new((0.0, 7.3), 10).ticks,
            vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]
        );
        assert_eq!(Axis::new((-3.2, 3.2), 6).ticks, vec![-2.0, 0.0, 2.0]);
        assert_eq!(
            Axis::new((0.0, 10.0), 5).ticks,
            vec![0.0, 2.0, 4.0, 6.0, 8.0, 10.0]
        );
        assert_eq!(
            Axis::new((0.0, 1.0), 5).labels,
            ["0.0", "0.2", "0.4", "0.6", "0.8", "1.0"]
        );
        assert_eq!(
            Axis::new((-0.013, 0.021), 4).labels,
            ["-0.01", "0.00", "0.01", "0.02"]
        );
        assert_eq!(Axis::new((0.0, 3.0e6), 3).labels, ["0", "1e6", "2e6", "3e6"]);
        assert_eq!(
            Axis::new((0.0, 2.5e-5), 5).labels,
            ["0", "5.0e-6", "1.0e-5", "1.5e-5", "2.0e-5", "2.5e-5"]
        );
        for (lo, hi, target) in [(0.0, 7.3, 5), (-1e-3, 4e-3, 7), (12.0, 13.0, 3), (-5e4, 1e5, 8)] {
            let a = Axis::new((lo, hi), target);
            let m = a.step / 10f64.powf((a.step.log10() + 1e-9).floor());
            assert!(
                [1.0, 2.0, 5.0].iter().any(|n| (m - n).abs() < 1e-9),
                "step {}",
                a.step
            );
            assert!(a.step >= (hi - lo) / target as f64 * (1.0 - 1e-9));
            assert!(a.ticks.len() >= 2, "{:?}", a.ticks);
            assert!(a.ticks.iter().all(|&t| t >= lo - 1e-12 && t <= hi + 1e-12));
        }
        assert!(Axis::new((0.0, f64::INFINITY), 5).ticks.is_empty());
    }

    #[test]
    fn ranges_ignore_non_finite_and_widen_flat_data() {
        assert_eq!(axis_range(None, 0.05), (0.0, 1.0));
        assert_eq!(axis_range(Some((0.0, 0.0)), 0.05), (-1.0, 1.0));
        let (lo, hi) = axis_range(Some((3.0, 3.0)), 0.05);
        assert!((lo - 2.7).abs() < 1e-12 && (hi - 3.3).abs() < 1e-12);
        assert_eq!(axis_range(Some((0.0, 10.0)), 0.05), (-0.5, 10.5));
        let s = series(
            "s",
            vec![0.0, 1.0, f64::NAN, 3.0, 4.0],
            vec![1.0, f64::INFINITY, 5.0, -2.0, 0.0],
        );
        assert_eq!(min_max(finite_points(&s).map(|p| p.1)), Some((-2.0, 1.0)));
        let (lo, hi) = axis_range(Some((-f64::MAX, f64::MAX)), 0.05);
        assert!(lo.is_finite() && hi.is_finite());
    }

    #[test]
    fn non_finite_values_break_lines_and_break_nothing_else() {
        let nan = f64::NAN;
        let fig = Figure {
            title: "NaN".into(),
            x_label: "t".into(),
            panels: vec![
                Panel {
                    title: "gaps".into(),
                    y_label: "y".into(),
                    series: vec![
                        series(
                            "gap",
                            vec![0.0, 1.0, 2.0, 3.0, 4.0],
                            vec![0.0, 1.0, nan, 1.0, 0.0],
                        ),
                        series("all NaN", vec![nan, nan], vec![nan, nan]),
                        series("lone", vec![0.0, 1.0, 2.0], vec![nan, 2.0, f64::NEG_INFINITY]),
                        series("flat", vec![0.0, 4.0], vec![0.5, 0.5]),
                        series("short y", vec![0.0, 1.0, 2.0], vec![0.3]),
                    ],
                },
                Panel {
                    title: "empty".into(),
                    y_label: String::new(),
                    series: vec![],
                },
                Panel {
                    title: "flat only".into(),
                    y_label: String::new(),
                    series: vec![series("c", vec![0.0, 4.0], vec![7.0, 7.0])],
                },
            ],
        };
        let svg = to_svg(&fig, 800, 600);
        for bad in ["NaN,", ",NaN", "inf"] {
            assert!(!svg.contains(bad), "{bad}");
        }
        // "gap": two runs; "lone" and "short y": a dot each; "flat" and "c": one each; "all NaN":
        // none.
        assert_eq!(svg.matches("<polyline").count(), 2 + 1 + 1 + 1 + 1);
        let (info, _) = decode(&to_png(&fig, 800, 600));
        assert_eq!((info.width, info.height), (800, 600));
        // The empty panel still has its frame and ticks.
        let l = layout(&fig, 800, 600);
        assert!(!l.panels[1].1.ticks.is_empty());
        let empty = Figure {
            title: String::new(),
            x_label: String::new(),
            panels: vec![],
        };
        assert!(to_svg(&empty, 200, 100).contains("</svg>"));
        decode(&to_png(&empty, 200, 100));
    }

    #[test]
    fn long_series_are_reduced_per_pixel_column() {
        let n = 100_000;
        let x: Vec<f64> = (0..n).map(|i| i as f64 * 1e-3).collect();
        let y: Vec<f64> = x
            .iter()
            .map(|t| (3.0 * t).sin() + 0.3 * (1700.0 * t).sin())
            .collect();
        let fig = Figure {
            title: "Long".into(),
            x_label: "t, s".into(),
            panels: vec![Panel {
                title: String::new(),
                y_label: "y".into(),
                series: vec![series("y", x, y)],
            }],
        };
        let svg = to_svg(&fig, 1200, 400);
        assert!(svg.len() < 200_000, "{} bytes", svg.len());
        let l = layout(&fig, 1200, 400);
        let (r, ya) = &l.panels[0];
        let runs = reduce(&fig.panels[0].series[0], &l.x_axis, ya, *r);
        assert_eq!(runs.len(), 1);
        assert!(
            runs[0].len() <= 4 * (r.w as usize + 1),
            "{} points",
            runs[0].len()
        );
        // The extremes survive the reduction.
        let (lo, hi) = min_max(runs[0].iter().map(|p| p.1)).unwrap();
        assert!((lo - r.y).abs() < 0.06 * r.h && (r.y + r.h - hi).abs() < 0.06 * r.h);
        decode(&to_png(&fig, 1200, 400));
    }

    #[test]
    fn output_is_deterministic() {
        let fig = line_figure();
        assert_eq!(to_svg(&fig, 640, 480), to_svg(&fig, 640, 480));
        assert_eq!(to_png(&fig, 640, 480), to_png(&fig, 640, 480));
    }

    #[test]
    fn legend_truncates_long_labels_and_counts_the_rest() {
        let many: Vec<Series> = (0..40)
            .map(|i| series(&format!("series {i}"), vec![0.0, 1.0], vec![0.0, i as f64]))
            .collect();
        let mut fig = line_figure();
        fig.panels[0].series = many;
        fig.panels[0].series[0].label = "x".repeat(500);
        let svg = to_svg(&fig, 800, 300);
        assert!(svg.contains("more</text>"));
        assert!(!svg.contains(&"x".repeat(200)));
        assert_eq!(truncate("abcdef", 4), "ab..");
        assert_eq!(truncate("abc", 4), "abc");
    }

    #[test]
    fn every_printable_glyph_but_space_has_ink() {
        for c in '!'..='~' {
            assert!(glyph(c).iter().any(|&b| b != 0), "{c:?}");
        }
        assert_eq!(glyph('τ'), glyph('?'));
    }

    /// A figure like the simulator's: four panels of three noisy 10 s series at 1 kHz.
    fn four_panel_figure() -> Figure {
        let x: Vec<f64> = (0..10_001).map(|i| f64::from(i) * 1e-3).collect();
        let panels = (0..4)
            .map(|p| Panel {
                title: format!("Panel {p}"),
                y_label: "N m".into(),
                series: (0..3)
                    .map(|s| {
                        let (a, f) = (1.0 + f64::from(p + s), 0.2 + 0.15 * f64::from(p + s));
                        let y = x
                            .iter()
                            .map(|t| {
                                a * (std::f64::consts::TAU * f * t).sin()
                                    + 0.1 * a * (37.0 * t * f64::from(s + 1)).sin()
                            })
                            .collect();
                        series(&format!("tau{s}"), x.clone(), y)
                    })
                    .collect(),
            })
            .collect();
        Figure {
            title: "Joint moments".into(),
            x_label: "t, s".into(),
            panels,
        }
    }

    #[test]
    fn compressed_figure_decodes_to_the_drawn_pixels() {
        let fig = four_panel_figure();
        let bytes = to_png(&fig, 1200, 900);
        let (info, buf) = decode(&bytes);
        assert_eq!((info.width, info.height), (1200, 900));
        // Not assert_eq!: a failure would print two 3.2 MB buffers.
        assert!(buf == render(&fig, 1200, 900).rgb, "decoded pixels differ");
        // 3.2 MB of pixels; about 264 kB when written.
        assert!(bytes.len() < 330_000, "{} bytes", bytes.len());
    }

    /// Deterministic pseudo-random bytes (xorshift64*).
    fn noise(n: usize, seed: u64) -> Vec<u8> {
        let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        (0..n)
            .map(|_| {
                s ^= s >> 12;
                s ^= s << 25;
                s ^= s >> 27;
                (s.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 56) as u8
            })
            .collect()
    }

    #[test]
    fn deflate_round_trips_through_an_inflater() {
        // Copies from 1 byte to the whole window back (log-uniformly), of every length, overlapping
        // or not, between literals: every length and distance code.
        let r = noise(50_000, 3);
        let mut mixed = noise(33_000, 2);
        for k in r.chunks_exact(5) {
            let len = 3 + usize::from(u16::from_le_bytes([k[0], k[1]]) % 300);
            let dist = 1 + usize::from(u16::from_le_bytes([k[2], k[3]]) >> (k[4] % 16)) / 2;
            for _ in 0..len {
                mixed.push(mixed[mixed.len() - dist]);
            }
            mixed.extend_from_slice(&k[..usize::from(k[4] / 64)]);
        }
        let mut far = noise(WINDOW, 4);
        far.extend_from_within(..);
        let cases = [
            (vec![], 0),
            (vec![7], 0),
            (vec![1, 2], 0),
            (vec![0; 3], 0),
            (vec![0; 100_000], 0),
            (noise(70_000, 1), 0),
            (b"abcabcabcabd".repeat(5000), 0),
            (mixed.clone(), 0),
            (mixed.clone(), 3601),
            (mixed, WINDOW),
            (far.clone(), 0),
            (far, WINDOW + 1),
            (b"row one|row two|row one|".repeat(900), 8),
        ];
        for (data, row) in cases {
            let z = zlib(&data, row);
            let back = miniz_oxide::inflate::decompress_to_vec_zlib(&z).expect("valid zlib stream");
            assert!(back == data, "{} bytes, row {row}", data.len());
            // Fixed codes cost at most 9 bits a literal.
            assert!(
                z.len() <= data.len() * 9 / 8 + 10,
                "{} -> {}",
                data.len(),
                z.len()
            );
        }
        // Repetitive input shrinks. A run or a short period: about 13 to 15 bits per 258 bytes.
        assert!(zlib(&[0; 100_000], 0).len() < 700);
        assert!(zlib(&b"abcabcabcabd".repeat(5000), 0).len() < 500);
        // Noise repeated from exactly 32 KiB back: the repeat costs next to nothing.
        let once = noise(WINDOW, 4);
        let twice = [&once[..], &once[..]].concat();
        assert!(zlib(&twice, 0).len() < zlib(&once, 0).len() + 500);
    }

    #[test]
    fn a_short_axis_still_gets_two_ticks() {
        // ±4.4 on a short panel: the spacing alone asks for a step of 5, which leaves only 0.
        for len in [20.0, 40.0, 80.0] {
            let a = Axis::fitted((-4.4, 4.4), len, 12.0, None);
            assert!(a.ticks.len() >= 2, "{len}: {:?}", a.ticks);
            assert!(a.ticks.iter().all(|t| (-4.4..=4.4).contains(t)));
        }
    }
}
