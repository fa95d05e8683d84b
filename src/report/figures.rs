//! Figures of one solved case, as in section 5.3 of the paper (figures 5.2 and 5.3).
//!
//! Drawn with `plotters`. Text is rasterised by `ab_glyph` from a font embedded in the
//! binary (a subset of DejaVu Sans, `src/report/font/`), so neither building nor running
//! needs fontconfig, freetype or any installed font: PNG output works on a bare machine.
//! PNG is the default format ([`FigureFormat::Png`]); SVG ([`FigureFormat::Svg`]) is
//! available for vector output (its text is SVG `<text>` in the viewer's sans-serif font).
//!
//! Every file is rendered in memory and then written with [`write_atomic`].

use super::{norm, write_atomic, EnergyEllipsoid, ReportError, TrajectoryTable};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The embedded font (DejaVu Sans subset: Latin, Greek, math symbols, sub/superscripts).
static FONT_BYTES: &[u8] = include_bytes!("font/DejaVuSans-subset.ttf");

/// Font family name used for all text.
const FAMILY: &str = "sans-serif";

/// Colours of the three components (κ₁/Ω₁, κ₂/Ω₂, κ₃/Ω₃): blue, orange, purple; green and red
/// are reserved for the start and end markers.
const COMPONENT_COLORS: [RGBColor; 3] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
];
/// Ω in the 3-D view.
const OMEGA_COLOR: RGBColor = RGBColor(31, 119, 180);
/// Ω_d in the 3-D view.
const DESIRED_COLOR: RGBColor = RGBColor(0, 0, 0);
/// ξ_∥ in the 3-D view.
const XI_COLOR: RGBColor = RGBColor(255, 127, 14);
/// Start marker.
const START_COLOR: RGBColor = RGBColor(0, 170, 0);
/// End marker.
const END_COLOR: RGBColor = RGBColor(220, 0, 0);
/// Marker of Ω_d(b) when Ω_d is drawn beyond the terminal time.
const YELLOW_MARKER: RGBColor = RGBColor(240, 200, 0);

/// Output format of the figures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FigureFormat {
    /// Raster PNG (text rendered from the embedded font). The default.
    #[default]
    Png,
    /// Vector SVG.
    Svg,
}

impl FigureFormat {
    /// File extension without the dot: `"png"` or `"svg"`.
    pub fn extension(self) -> &'static str {
        match self {
            FigureFormat::Png => "png",
            FigureFormat::Svg => "svg",
        }
    }
}

/// The figures of one case, with their file stems (the file is `<stem>.<extension>`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Figure {
    /// `omega_3d`: 3-D view of Ω(t), Ω_d(t) and ξ_∥(t) with the ellipsoid `E`.
    Omega3d,
    /// `constraint`: ⟨Ω, ξ⟩ against t.
    Constraint,
    /// `xi_norm`: |ξ| against t.
    XiNorm,
    /// `kappa`: κ₁, κ₂, κ₃ against t.
    Kappa,
    /// `omega`: components of Ω and Ω_d against t.
    OmegaComponents,
}

impl Figure {
    /// All figures, in the order [`write_case_figures`] writes them.
    pub const ALL: [Figure; 5] = [
        Figure::Omega3d,
        Figure::Constraint,
        Figure::XiNorm,
        Figure::Kappa,
        Figure::OmegaComponents,
    ];

    /// File stem: `omega_3d`, `constraint`, `xi_norm`, `kappa` or `omega`.
    pub fn stem(self) -> &'static str {
        match self {
            Figure::Omega3d => "omega_3d",
            Figure::Constraint => "constraint",
            Figure::XiNorm => "xi_norm",
            Figure::Kappa => "kappa",
            Figure::OmegaComponents => "omega",
        }
    }
}

/// Default `(yaw, pitch)` of the 3-D figure.
pub const DEFAULT_VIEW_3D: (f64, f64) = (-0.5, 0.35);

/// How to draw the figures of one case.
#[derive(Debug, Clone, PartialEq)]
pub struct FigureOptions {
    /// Case name shown in every title, e.g. `"eta = 1"`.
    pub title: String,
    /// The energy ellipsoid `E` (for ξ_∥ and the wireframe).
    pub ellipsoid: EnergyEllipsoid,
    /// PNG or SVG.
    pub format: FigureFormat,
    /// Width and height in pixels.
    pub size: (u32, u32),
    /// Optionally Ω_d sampled on a longer horizon than the solution (e.g. up to the desired
    /// terminal time `b_d` when the optimal `b < b_d`). When given, this curve is drawn as
    /// Ω_d and a yellow marker shows Ω_d(b), the last row of the table (as in the paper's
    /// figure 5.3a).
    pub desired_extended: Option<Vec<[f64; 3]>>,
    /// View of the 3-D figure: `(yaw, pitch)` in radians (plotters' projection angles; yaw
    /// turns about the vertical Ω₃ axis, pitch tilts towards a view from above).
    pub view_3d: (f64, f64),
}

impl FigureOptions {
    /// PNG, 1200 × 900 pixels, no extended Ω_d.
    pub fn new(title: impl Into<String>, ellipsoid: EnergyEllipsoid) -> Self {
        Self {
            title: title.into(),
            ellipsoid,
            format: FigureFormat::Png,
            size: (1200, 900),
            desired_extended: None,
            view_3d: DEFAULT_VIEW_3D,
        }
    }
}

/// Draws all figures of [`Figure::ALL`] into `dir` (created, with its parents, if missing),
/// each written atomically, and returns their paths.
///
/// # Errors
/// [`ReportError::LengthMismatch`] / [`ReportError::EmptyTable`] /
/// [`ReportError::InvalidInput`] for bad data (nothing is written), [`ReportError::Io`] or
/// [`ReportError::Plot`] naming the file that failed.
pub fn write_case_figures(
    dir: impl AsRef<Path>,
    table: &TrajectoryTable,
    opts: &FigureOptions,
) -> Result<Vec<PathBuf>, ReportError> {
    let dir = dir.as_ref();
    check_inputs(table, opts)?;
    std::fs::create_dir_all(dir).map_err(|source| ReportError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut paths = Vec::with_capacity(Figure::ALL.len());
    for fig in Figure::ALL {
        let path = dir.join(format!("{}.{}", fig.stem(), opts.format.extension()));
        write_figure(&path, fig, table, opts)?;
        paths.push(path);
    }
    Ok(paths)
}

/// Draws one figure to `path` (format from `opts.format`, whatever the extension of `path`),
/// atomically; the parent directory must exist.
///
/// # Errors
/// As [`write_case_figures`].
pub fn write_figure(
    path: impl AsRef<Path>,
    figure: Figure,
    table: &TrajectoryTable,
    opts: &FigureOptions,
) -> Result<(), ReportError> {
    let path = path.as_ref();
    check_inputs(table, opts)?;
    let bytes = render_figure(figure, table, opts).map_err(|message| ReportError::Plot {
        path: path.to_path_buf(),
        message,
    })?;
    write_atomic(path, &bytes)
}

/// Renders one figure in memory: the bytes of a PNG or SVG file.
///
/// # Errors
/// As [`write_case_figures`], with [`ReportError::Plot`] naming the figure stem.
pub fn render_figure_bytes(
    figure: Figure,
    table: &TrajectoryTable,
    opts: &FigureOptions,
) -> Result<Vec<u8>, ReportError> {
    check_inputs(table, opts)?;
    render_figure(figure, table, opts).map_err(|message| ReportError::Plot {
        path: PathBuf::from(figure.stem()),
        message,
    })
}

fn check_inputs(table: &TrajectoryTable, opts: &FigureOptions) -> Result<(), ReportError> {
    table.validate()?;
    if table.is_empty() {
        return Err(ReportError::EmptyTable);
    }
    opts.ellipsoid.check()?;
    let (w, h) = opts.size;
    if !(200..=8000).contains(&w) || !(150..=8000).contains(&h) {
        return Err(ReportError::InvalidInput(format!(
            "figure size {w}x{h} outside 200x150 .. 8000x8000"
        )));
    }
    Ok(())
}

/// Registers the embedded font once (for the families plotters may ask for).
fn ensure_font() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            for family in [FAMILY, "serif", "monospace"] {
                register_font(family, FontStyle::Normal, FONT_BYTES)
                    .map_err(|_| "embedded font is invalid".to_string())?;
            }
            Ok(())
        })
        .clone()
}

fn render_figure(
    figure: Figure,
    table: &TrajectoryTable,
    opts: &FigureOptions,
) -> Result<Vec<u8>, String> {
    ensure_font()?;
    let (w, h) = opts.size;
    match opts.format {
        FigureFormat::Png => {
            // Drawn at SUPERSAMPLE times the size and averaged down: plotters' bitmap lines
            // are not anti-aliased.
            let (sw, sh) = (w * SUPERSAMPLE, h * SUPERSAMPLE);
            let mut big = vec![0u8; sw as usize * sh as usize * 3];
            {
                let root = BitMapBackend::with_buffer(&mut big, (sw, sh)).into_drawing_area();
                draw(&root, figure, table, opts)?;
                root.present().map_err(|e| e.to_string())?;
            }
            encode_png(&downsample(&big, w, h, SUPERSAMPLE), w, h)
        }
        FigureFormat::Svg => {
            let mut svg = String::new();
            {
                let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
                draw(&root, figure, table, opts)?;
                root.present().map_err(|e| e.to_string())?;
            }
            Ok(svg.into_bytes())
        }
    }
}

/// Supersampling factor of PNG rendering.
const SUPERSAMPLE: u32 = 2;

/// Box-filters an RGB image of size `(w·k) × (h·k)` down to `w × h`.
fn downsample(big: &[u8], w: u32, h: u32, k: u32) -> Vec<u8> {
    let (w, h, k) = (w as usize, h as usize, k as usize);
    let big_w = w * k;
    let mut out = vec![0u8; w * h * 3];
    for y in 0..h {
        for x in 0..w {
            for c in 0..3 {
                let mut sum = 0u32;
                for dy in 0..k {
                    let row = (y * k + dy) * big_w;
                    for dx in 0..k {
                        sum += u32::from(big[(row + x * k + dx) * 3 + c]);
                    }
                }
                let n = (k * k) as u32;
                out[(y * w + x) * 3 + c] = ((sum + n / 2) / n) as u8;
            }
        }
    }
    out
}

fn encode_png(rgb: &[u8], w: u32, h: u32) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc.write_header().map_err(|e| e.to_string())?;
        writer.write_image_data(rgb).map_err(|e| e.to_string())?;
        writer.finish().map_err(|e| e.to_string())?;
    }
    Ok(out)
}

/// Font sizes scaled with the figure height (reference: 900 px).
struct Fonts {
    title: f64,
    desc: f64,
    label: f64,
    legend: f64,
}

impl Fonts {
    fn for_size((_, h): (u32, u32)) -> Self {
        let s = f64::from(h) / 900.0;
        Self {
            title: 34.0 * s,
            desc: 28.0 * s,
            label: 22.0 * s,
            legend: 24.0 * s,
        }
    }
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    figure: Figure,
    table: &TrajectoryTable,
    opts: &FigureOptions,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let segmented = opts.format == FigureFormat::Png;
    let result = match figure {
        Figure::Omega3d => draw_omega_3d(root, table, opts),
        Figure::Constraint => {
            let c = table.constraint();
            let max = c
                .iter()
                .filter(|v| v.is_finite())
                .fold(0.0f64, |m, v| m.max(v.abs()));
            let series = [Series::new("⟨Ω, ξ⟩", COMPONENT_COLORS[0], &table.t, &c)];
            draw_time_series(
                root,
                TimePlot {
                    caption: format!(
                        "Constraint ⟨Ω, ξ⟩ ({}); max |⟨Ω, ξ⟩| = {max:.2e}",
                        opts.title
                    ),
                    y_desc: "⟨Ω, ξ⟩",
                    series: &series,
                    y_axis: YAxis::Symmetric,
                    end_markers: false,
                    reference: None,
                    dashed_note: None,
                    segmented,
                },
            )
        }
        Figure::XiNorm => {
            let n = table.xi_norm();
            let series = [Series::new("|ξ|", COMPONENT_COLORS[0], &table.t, &n)];
            draw_time_series(
                root,
                TimePlot {
                    caption: format!("Magnitude of the control vector |ξ| ({})", opts.title),
                    y_desc: "|ξ|",
                    series: &series,
                    y_axis: YAxis::Auto,
                    end_markers: false,
                    reference: Some((1.0, "|ξ| = 1")),
                    dashed_note: None,
                    segmented,
                },
            )
        }
        Figure::Kappa => {
            let cols: Vec<Vec<f64>> = (0..3)
                .map(|k| table.kappa.iter().map(|v| v[k]).collect())
                .collect();
            let names = ["κ₁", "κ₂", "κ₃"];
            let series: Vec<Series> = (0..3)
                .map(|k| Series::new(names[k], COMPONENT_COLORS[k], &table.t, &cols[k]))
                .collect();
            draw_time_series(
                root,
                TimePlot {
                    caption: format!("Costates κ(t) ({})", opts.title),
                    y_desc: "κ",
                    series: &series,
                    y_axis: YAxis::Auto,
                    end_markers: true,
                    reference: None,
                    dashed_note: None,
                    segmented,
                },
            )
        }
        Figure::OmegaComponents => {
            let om: Vec<Vec<f64>> = (0..3)
                .map(|k| table.omega.iter().map(|v| v[k]).collect())
                .collect();
            let od: Vec<Vec<f64>> = (0..3)
                .map(|k| table.omega_d.iter().map(|v| v[k]).collect())
                .collect();
            let names = ["Ω₁", "Ω₂", "Ω₃"];
            let mut series: Vec<Series> = (0..3)
                .map(|k| Series::new(names[k], COMPONENT_COLORS[k], &table.t, &om[k]))
                .collect();
            for k in 0..3 {
                // Unlabelled: one "dashed: Ω_d" legend entry explains all three.
                let mut s = Series::new("", COMPONENT_COLORS[k], &table.t, &od[k]);
                s.dashed = true;
                series.push(s);
            }
            draw_time_series(
                root,
                TimePlot {
                    caption: format!("Body angular velocity Ω and desired Ω_d ({})", opts.title),
                    y_desc: "Ω",
                    series: &series,
                    y_axis: YAxis::Auto,
                    end_markers: false,
                    reference: None,
                    dashed_note: Some("dashed: Ω_d"),
                    segmented,
                },
            )
        }
    };
    result.map_err(|e| e.to_string())
}

/// Draws a wide polyline on a chart (2-D or 3-D) and evaluates to the series annotation.
/// With `$segmented` (bitmap output) the line is drawn segment by segment with round joins:
/// plotters joins wide polylines with unlimited miters, which shoot far out of the plot at
/// the sharp turns of noisy data (the constraint is rounding noise). SVG viewers apply a
/// miter limit themselves, so SVG output keeps one compact `<polyline>`.
macro_rules! draw_polyline {
    ($chart:expr, $points:expr, $color:expr, $width:expr, $segmented:expr) => {{
        let points = $points;
        let color: RGBColor = $color;
        let width: u32 = $width;
        let style = color.stroke_width(width);
        if $segmented {
            let join = (f64::from(width) / 2.0).floor() as i32;
            if join >= 1 {
                $chart.draw_series(points.iter().map(|&p| Circle::new(p, join, color.filled())))?;
            }
            $chart.draw_series(
                points
                    .windows(2)
                    .map(|w| PathElement::new(vec![w[0], w[1]], style)),
            )?
        } else {
            $chart.draw_series(LineSeries::new(points.iter().copied(), style))?
        }
    }};
}

/// What a time-series figure shows.
struct TimePlot<'a> {
    caption: String,
    y_desc: &'a str,
    series: &'a [Series<'a>],
    y_axis: YAxis,
    /// Green / red markers at the first / last point of every curve.
    end_markers: bool,
    /// A dashed horizontal reference line `(value, legend label)`.
    reference: Option<(f64, &'a str)>,
    /// A legend entry with a grey dashed sample explaining the dashed curves.
    dashed_note: Option<&'a str>,
    /// Bitmap output: draw polylines segment by segment (see `draw_polyline!`).
    segmented: bool,
}

/// One curve of a time-series plot.
struct Series<'a> {
    name: &'a str,
    color: RGBColor,
    t: &'a [f64],
    y: &'a [f64],
    dashed: bool,
}

impl<'a> Series<'a> {
    fn new(name: &'a str, color: RGBColor, t: &'a [f64], y: &'a [f64]) -> Self {
        Self {
            name,
            color,
            t,
            y,
            dashed: false,
        }
    }
}

/// How to choose the y range.
#[derive(Clone, Copy, PartialEq)]
enum YAxis {
    /// Data range, padded.
    Auto,
    /// Symmetric about zero (for quantities that should vanish), scientific labels.
    Symmetric,
}

/// Splits a curve into maximal runs of finite points (NaN / inf break the line).
fn finite_runs(t: &[f64], y: &[f64]) -> Vec<Vec<(f64, f64)>> {
    let mut runs = Vec::new();
    let mut cur = Vec::new();
    for (&a, &b) in t.iter().zip(y) {
        if a.is_finite() && b.is_finite() {
            cur.push((a, b));
        } else if !cur.is_empty() {
            runs.push(std::mem::take(&mut cur));
        }
    }
    if !cur.is_empty() {
        runs.push(cur);
    }
    runs
}

/// Finite (min, max) of the values, or `None`.
fn finite_range<'a>(values: impl Iterator<Item = &'a f64>) -> Option<(f64, f64)> {
    values
        .filter(|v| v.is_finite())
        .fold(None, |acc, &v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
        })
}

/// Pads a data range by 5 % on each side; a degenerate range gets a sensible width.
fn padded((lo, hi): (f64, f64)) -> (f64, f64) {
    let magnitude = lo.abs().max(hi.abs());
    if magnitude == 0.0 {
        return (-1.0, 1.0);
    }
    let span = hi - lo;
    if span <= 1e-9 * magnitude {
        let half = 0.05 * magnitude;
        return (lo - half, hi + half);
    }
    (lo - 0.05 * span, hi + 0.05 * span)
}

/// Maximum number of tick labels per axis.
const MAX_TICKS: usize = 10;

/// The tick step plotters chooses for `[lo, hi]` with at most `max_points` ticks (the same
/// search as its `f64` key points: 1, 2 or 5 times a power of ten).
fn tick_step(lo: f64, hi: f64, max_points: usize) -> f64 {
    let span = hi - lo;
    if !(span > 0.0 && span.is_finite()) {
        return 1.0;
    }
    let mut scale = 10f64.powf(span.log10().floor());
    if 1.0 + (span / scale).floor() > max_points as f64 {
        scale *= 10.0;
    }
    for _ in 0..64 {
        let old = scale;
        for nxt in [2.0, 5.0, 10.0] {
            let step = old / nxt;
            let left = (lo / step).ceil() * step;
            let right = (hi / step).floor() * step;
            if (1.0 + (right - left) / step).round() > max_points as f64 {
                return scale;
            }
            scale = step;
        }
    }
    scale
}

/// Tick label with as many decimals as the tick step needs (and no `-0`).
fn tick_label(v: f64, step: f64) -> String {
    let digits = (-step.log10() - 1e-9).ceil().clamp(0.0, 12.0) as usize;
    let v = if v.abs() < 1e-6 * step { 0.0 } else { v };
    format!("{v:.digits$}")
}

/// `10^e` written with Unicode superscripts, e.g. `10⁻¹²`.
fn power_of_ten(e: i32) -> String {
    const SUP: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let mut s = String::from("10");
    if e < 0 {
        s.push('⁻');
    }
    for c in e.unsigned_abs().to_string().chars() {
        s.push(SUP[c.to_digit(10).unwrap_or(0) as usize]);
    }
    s
}

/// The power of ten by which values of this magnitude are divided for plotting (0 when they
/// read well as they are).
fn display_exponent(magnitude: f64) -> i32 {
    if magnitude > 0.0 && magnitude.is_finite() && !(1e-2..1e4).contains(&magnitude) {
        magnitude.log10().floor() as i32
    } else {
        0
    }
}

/// Legend corners, tried in this order.
const LEGEND_CORNERS: [SeriesLabelPosition; 4] = [
    SeriesLabelPosition::UpperRight,
    SeriesLabelPosition::LowerRight,
    SeriesLabelPosition::UpperLeft,
    SeriesLabelPosition::LowerLeft,
];

/// The corner whose legend box (`w × h`, as fractions of the plotting area) covers the fewest
/// data points (`points` in `[0,1]²`, y upwards), and that count.
fn best_legend_corner(points: &[(f64, f64)], w: f64, h: f64) -> (SeriesLabelPosition, usize) {
    let count = |right: bool, upper: bool| {
        points
            .iter()
            .filter(|(u, v)| {
                let in_u = if right { *u >= 1.0 - w } else { *u <= w };
                let in_v = if upper { *v >= 1.0 - h } else { *v <= h };
                in_u && in_v
            })
            .count()
    };
    let counts = [
        count(true, true),
        count(true, false),
        count(false, true),
        count(false, false),
    ];
    let mut best = 0;
    for k in 1..4 {
        if counts[k] < counts[best] {
            best = k;
        }
    }
    (LEGEND_CORNERS[best].clone(), counts[best])
}

fn draw_time_series<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: TimePlot,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let TimePlot {
        caption,
        y_desc,
        series,
        y_axis,
        end_markers,
        reference,
        dashed_note,
        segmented,
    } = plot;
    let (root_w, root_h) = root.dim_in_pixel();
    let f = Fonts::for_size((root_w, root_h));
    let hs = f64::from(root_h) / 900.0;
    let (t0, t1) = finite_range(series.iter().flat_map(|s| s.t.iter())).unwrap_or((0.0, 1.0));
    let (t0, t1) = if t1 > t0 { (t0, t1) } else { padded((t0, t1)) };
    let data = finite_range(
        series
            .iter()
            .flat_map(|s| s.y.iter())
            .chain(reference.as_ref().map(|(v, _)| v)),
    );
    let magnitude = data.map_or(0.0, |(lo, hi)| lo.abs().max(hi.abs()));
    // Very small or large values are plotted in units of 10^e (plotters' tick search needs
    // O(1) numbers; the constraint is ~1e-12).
    let e = display_exponent(magnitude);
    let unit = 10f64.powi(e);
    let (y0, mut y1) = match y_axis {
        YAxis::Symmetric => {
            let m = magnitude / unit;
            let m = if m > 0.0 { 1.15 * m } else { 1.0 };
            (-m, m)
        }
        YAxis::Auto => padded(data.map_or((-1.0, 1.0), |(lo, hi)| (lo / unit, hi / unit))),
    };
    let runs: Vec<Vec<Vec<(f64, f64)>>> = series
        .iter()
        .map(|s| {
            finite_runs(s.t, s.y)
                .into_iter()
                .map(|run| run.into_iter().map(|(a, b)| (a, b / unit)).collect())
                .collect()
        })
        .collect();
    let markers: Vec<((f64, f64), (f64, f64))> = if end_markers {
        runs.iter()
            .filter_map(|r| Some((*r.first()?.first()?, *r.last()?.last()?)))
            .collect()
    } else {
        Vec::new()
    };

    // Legend: entries, size, and a corner free of data; if every corner has data, head room
    // is added above the curves for it.
    let mut labels: Vec<&str> = series
        .iter()
        .map(|s| s.name)
        .filter(|n| !n.is_empty())
        .collect();
    labels.extend(reference.as_ref().map(|(_, l)| *l));
    labels.extend(dashed_note);
    if end_markers {
        labels.extend(["start", "end"]);
    }
    let entries = labels.len();
    let legend_len = (44.0 * hs) as i32;
    let legend_margin = 15.0 * hs;
    let max_chars = labels.iter().map(|l| l.chars().count()).max().unwrap_or(0);
    // Estimates of the plotting area and legend box sizes (label areas, margins, caption),
    // measured on rendered figures, slightly generous.
    let plot_w_est = (f64::from(root_w) - 170.0 * hs).max(1.0);
    let plot_h_est = (f64::from(root_h) - 150.0 * hs).max(1.0);
    let legend_w = (max_chars as f64 * 0.55 * f.legend
        + f64::from(legend_len)
        + 12.0 * hs
        + 2.5 * legend_margin)
        / plot_w_est;
    let legend_h = (entries as f64 * 1.2 * f.legend + 2.5 * legend_margin) / plot_h_est;
    let normalized = |y_top: f64| -> Vec<(f64, f64)> {
        let to_unit = |(a, b): (f64, f64)| ((a - t0) / (t1 - t0), (b - y0) / (y_top - y0));
        let mut pts: Vec<(f64, f64)> = runs
            .iter()
            .flatten()
            .flatten()
            .map(|&p| to_unit(p))
            .collect();
        // The legend must not hide a marker: they weigh like many curve points.
        for &(p, q) in &markers {
            pts.extend(std::iter::repeat_n(to_unit(p), 200));
            pts.extend(std::iter::repeat_n(to_unit(q), 200));
        }
        pts
    };
    let mut corner = SeriesLabelPosition::UpperRight;
    if entries > 1 {
        let (c, covered) = best_legend_corner(&normalized(y1), legend_w, legend_h);
        corner = c;
        if covered > 0 && legend_h < 0.6 {
            y1 = y0 + (y1 - y0) / (1.0 - legend_h - 0.02);
            corner = best_legend_corner(&normalized(y1), legend_w, legend_h).0;
        }
    }

    let y_desc = if e == 0 {
        y_desc.to_string()
    } else {
        format!("{y_desc}  [×{}]", power_of_ten(e))
    };
    let y_step = tick_step(y0, y1, MAX_TICKS);
    let t_step = tick_step(t0, t1, MAX_TICKS);
    let y_fmt = move |v: &f64| tick_label(*v, y_step);
    let t_fmt = move |v: &f64| tick_label(*v, t_step);

    let mut chart = ChartBuilder::on(root)
        .caption(&caption, (FAMILY, f.title))
        .margin((20.0 * hs) as u32)
        .x_label_area_size((70.0 * hs) as u32)
        .y_label_area_size((130.0 * hs) as u32)
        .build_cartesian_2d(t0..t1, y0..y1)?;
    chart
        .configure_mesh()
        .x_desc("t")
        .y_desc(y_desc)
        .x_labels(MAX_TICKS)
        .y_labels(MAX_TICKS)
        .axis_desc_style((FAMILY, f.desc))
        .label_style((FAMILY, f.label))
        .x_label_formatter(&t_fmt)
        .y_label_formatter(&y_fmt)
        .light_line_style(BLACK.mix(0.04))
        .bold_line_style(BLACK.mix(0.15))
        .draw()?;

    // Noise-like data (the constraint) reads better with a thinner line.
    let line_px = if y_axis == YAxis::Symmetric { 1.5 } else { 2.5 };
    let width = (line_px * hs).max(1.0) as u32;
    let (plot_w, plot_h) = chart.plotting_area().dim_in_pixel();
    let px_per_t = f64::from(plot_w) / (t1 - t0);
    let px_per_y = f64::from(plot_h) / (y1 - y0);
    let dashed_legend = move |(x, y): (i32, i32), style: ShapeStyle| {
        let d = legend_len * 2 / 5;
        EmptyElement::at((x, y))
            + PathElement::new(vec![(0, 0), (d, 0)], style)
            + PathElement::new(vec![(legend_len - d, 0), (legend_len, 0)], style)
    };
    for (s, s_runs) in series.iter().zip(&runs) {
        let style = s.color.stroke_width(width);
        let mut first = true;
        for run in s_runs {
            let run = thin_out(run, 1.5 * hs, |p, q| {
                (((p.0 - q.0) * px_per_t).powi(2) + ((p.1 - q.1) * px_per_y).powi(2)).sqrt()
            });
            let anno = if s.dashed {
                let dash = (14.0 * hs) as u32;
                chart.draw_series(DashedLineSeries::new(run, dash, dash * 2 / 3, style))?
            } else {
                draw_polyline!(chart, &run, s.color, width, segmented)
            };
            if first && !s.name.is_empty() {
                let dashed = s.dashed;
                anno.label(s.name).legend(move |(x, y)| {
                    if dashed {
                        dashed_legend((x, y), style)
                    } else {
                        // Same element type as the dashed sample: a full line plus an empty
                        // second path.
                        EmptyElement::at((x, y))
                            + PathElement::new(vec![(0, 0), (legend_len, 0)], style)
                            + PathElement::new(vec![(0, 0), (0, 0)], style)
                    }
                });
            }
            first = false;
        }
    }
    if let Some((v, label)) = reference {
        let v = v / unit;
        let style = BLACK.mix(0.5).stroke_width((1.5 * hs).max(1.0) as u32);
        let dash = (10.0 * hs) as u32;
        chart
            .draw_series(DashedLineSeries::new([(t0, v), (t1, v)], dash, dash, style))?
            .label(label)
            .legend(move |p| dashed_legend(p, style));
    }
    if let Some(note) = dashed_note {
        let style = BLACK.mix(0.6).stroke_width(width);
        chart
            .draw_series(std::iter::empty::<PathElement<(f64, f64)>>())?
            .label(note)
            .legend(move |p| dashed_legend(p, style));
    }
    if end_markers {
        let r = (7.0 * hs).max(2.0) as i32;
        for &(p, q) in &markers {
            chart.draw_series([
                Circle::new(p, r, START_COLOR.filled()),
                Circle::new(q, r, END_COLOR.filled()),
            ])?;
        }
        chart
            .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())?
            .label("start")
            .legend(move |(x, y)| Circle::new((x + legend_len / 2, y), r, START_COLOR.filled()));
        chart
            .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())?
            .label("end")
            .legend(move |(x, y)| Circle::new((x + legend_len / 2, y), r, END_COLOR.filled()));
    }
    if entries > 1 {
        chart
            .configure_series_labels()
            .label_font((FAMILY, f.legend))
            .legend_area_size(legend_len + (12.0 * hs) as i32)
            .margin(legend_margin as u32)
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK.mix(0.4))
            .position(corner)
            .draw()?;
    }
    Ok(())
}

/// Points of an ellipsoid wireframe: `parallels` circles of constant Ω₃ and `meridians`
/// half-ellipses through the Ω₃ poles.
fn ellipsoid_wireframe(
    e: &EnergyEllipsoid,
    parallels: usize,
    meridians: usize,
) -> Vec<Vec<[f64; 3]>> {
    let [a, b, c] = e.semi_axes();
    let n = 72;
    let pi = std::f64::consts::PI;
    let mut lines = Vec::new();
    for i in 1..=parallels {
        let phi = pi * i as f64 / (parallels + 1) as f64;
        let (s, z) = (phi.sin(), c * phi.cos());
        lines.push(
            (0..=n)
                .map(|k| {
                    let th = 2.0 * pi * k as f64 / n as f64;
                    [a * s * th.cos(), b * s * th.sin(), z]
                })
                .collect(),
        );
    }
    for j in 0..meridians {
        let th = 2.0 * pi * j as f64 / meridians as f64;
        lines.push(
            (0..=n / 2)
                .map(|k| {
                    let phi = pi * k as f64 / (n / 2) as f64;
                    [
                        a * phi.sin() * th.cos(),
                        b * phi.sin() * th.sin(),
                        c * phi.cos(),
                    ]
                })
                .collect(),
        );
    }
    lines
}

/// Chart coordinates of a body vector: plotters' (x, y, z) with y vertical is right-handed
/// on screen, so the cyclic permutation x = Ω₂, y = Ω₃ (up), z = Ω₁ keeps the figure
/// un-mirrored.
fn to_chart(v: [f64; 3]) -> (f64, f64, f64) {
    (v[1], v[2], v[0])
}

/// Drops points closer than `min_dist` to the previously kept one (the last point is always
/// kept): plotters draws wide polylines segment by segment, and sub-pixel segments make
/// them ragged.
fn thin_out<P: Copy>(points: &[P], min_dist: f64, dist: impl Fn(P, P) -> f64) -> Vec<P> {
    let mut out: Vec<P> = Vec::with_capacity(points.len());
    for (i, &p) in points.iter().enumerate() {
        match out.last() {
            Some(&q) if i + 1 < points.len() && dist(p, q) < min_dist => {}
            _ => out.push(p),
        }
    }
    out
}

fn draw_omega_3d<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    table: &TrajectoryTable,
    opts: &FigureOptions,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let f = Fonts::for_size(root.dim_in_pixel());
    let hs = f64::from(root.dim_in_pixel().1) / 900.0;
    let segmented = opts.format == FigureFormat::Png;
    let e = &opts.ellipsoid;
    let omega: Vec<[f64; 3]> = table
        .omega
        .iter()
        .copied()
        .filter(|v| v.iter().all(|c| c.is_finite()))
        .collect();
    let desired: Vec<[f64; 3]> = opts
        .desired_extended
        .as_deref()
        .unwrap_or(&table.omega_d)
        .iter()
        .copied()
        .filter(|v| v.iter().all(|c| c.is_finite()))
        .collect();
    let xi_par: Vec<[f64; 3]> = table.xi_par(e).into_iter().flatten().collect();

    // One cube for all axes so that the ellipsoid keeps its true shape.
    let data_max = omega
        .iter()
        .chain(&desired)
        .chain(&xi_par)
        .flat_map(|v| v.iter())
        .fold(0.0f64, |m, c| m.max(c.abs()));
    let r = 1.08 * e.semi_axes().iter().fold(data_max, |m, &a| m.max(a));

    let mut chart = ChartBuilder::on(root)
        .caption(
            format!("Ω, Ω_d and ξ_∥ on the energy ellipsoid E ({})", opts.title),
            (FAMILY, f.title),
        )
        .margin((10.0 * hs) as u32)
        .build_cartesian_3d(-r..r, -r..r, -r..r)?;
    let (yaw, pitch) = opts.view_3d;
    chart.with_projection(|mut pb| {
        pb.yaw = yaw;
        pb.pitch = pitch;
        pb.scale = 0.9;
        pb.into_matrix()
    });
    let label_fmt = |v: &f64| format!("{v:.0}");
    chart
        .configure_axes()
        .label_style((FAMILY, f.label))
        .light_grid_style(BLACK.mix(0.05))
        .bold_grid_style(BLACK.mix(0.12))
        .max_light_lines(1)
        .x_formatter(&label_fmt)
        .y_formatter(&label_fmt)
        .z_formatter(&label_fmt)
        .draw()?;

    // Wireframe of E and the coordinate axes through the origin, with their names.
    let wire = BLACK.mix(0.13).stroke_width(1);
    for line in ellipsoid_wireframe(e, 7, 12) {
        chart.draw_series(LineSeries::new(line.into_iter().map(to_chart), wire))?;
    }
    let axis_style = BLACK.mix(0.45).stroke_width(1);
    let names = ["Ω₁", "Ω₂", "Ω₃"];
    for (k, name) in names.iter().enumerate() {
        let mut lo = [0.0; 3];
        let mut hi = [0.0; 3];
        lo[k] = -r;
        hi[k] = r;
        chart.draw_series(LineSeries::new([to_chart(lo), to_chart(hi)], axis_style))?;
        let mut at = [0.0; 3];
        at[k] = 1.04 * r;
        chart.draw_series(std::iter::once(Text::new(
            name.to_string(),
            to_chart(at),
            (FAMILY, f.desc).into_font().color(&BLACK),
        )))?;
    }

    let width = (2.5 * hs).max(1.0) as u32;
    let legend_len = (40.0 * hs) as i32;
    let curves: [(&str, &Vec<[f64; 3]>, RGBColor); 3] = [
        ("Ω (optimal)", &omega, OMEGA_COLOR),
        ("Ω_d (desired)", &desired, DESIRED_COLOR),
        ("ξ_∥ (control, on E)", &xi_par, XI_COLOR),
    ];
    for (name, pts, color) in curves {
        let thinned: Vec<(f64, f64, f64)> = thin_out(pts, 0.006 * r, |a, b| {
            norm([a[0] - b[0], a[1] - b[1], a[2] - b[2]])
        })
        .into_iter()
        .map(to_chart)
        .collect();
        draw_polyline!(chart, &thinned, color, width, segmented)
            .label(name)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + legend_len, y)], color.stroke_width(width))
            });
    }
    let rad = (8.0 * hs).max(2.0) as i32;
    for (_, pts, _) in curves {
        if let (Some(&p), Some(&q)) = (pts.first(), pts.last()) {
            chart.draw_series([
                Circle::new(to_chart(p), rad, START_COLOR.filled()),
                Circle::new(to_chart(q), rad, END_COLOR.filled()),
            ])?;
        }
    }
    chart
        .draw_series(std::iter::empty::<Circle<(f64, f64, f64), i32>>())?
        .label("start")
        .legend(move |(x, y)| Circle::new((x + legend_len / 2, y), rad, START_COLOR.filled()));
    chart
        .draw_series(std::iter::empty::<Circle<(f64, f64, f64), i32>>())?
        .label("end")
        .legend(move |(x, y)| Circle::new((x + legend_len / 2, y), rad, END_COLOR.filled()));
    if opts.desired_extended.is_some() {
        if let Some(&b) = table
            .omega_d
            .iter()
            .rev()
            .find(|v| v.iter().all(|c| c.is_finite()))
        {
            chart
                .draw_series(std::iter::once(Circle::new(
                    to_chart(b),
                    rad,
                    YELLOW_MARKER.filled().stroke_width(1),
                )))?
                .label("Ω_d(b)")
                .legend(move |(x, y)| {
                    Circle::new((x + legend_len / 2, y), rad, YELLOW_MARKER.filled())
                });
        }
    }
    chart
        .configure_series_labels()
        .label_font((FAMILY, f.legend))
        .legend_area_size(legend_len + (12.0 * hs) as i32)
        .margin((15.0 * hs) as u32)
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK.mix(0.4))
        .position(SeriesLabelPosition::UpperLeft)
        .draw()?;
    Ok(())
}

/// The planar path of a body (e.g. the steered sleigh on SE(2)): its reference point
/// `(x(t), y(t))` (`xs`, `ys`) with equal axis scales, start (green) and end (red) markers, and the body's
/// heading `θ(t)` drawn as short ticks at `headings` evenly spaced times. PNG, `size` pixels.
pub fn render_planar_path_png(
    title: &str,
    xs: &[f64],
    ys: &[f64],
    theta: &[f64],
    headings: usize,
    size: (u32, u32),
) -> Result<Vec<u8>, ReportError> {
    let n = xs.len();
    if n < 2 || ys.len() != n || theta.len() != n {
        return Err(ReportError::InvalidInput(format!(
            "a planar path needs >= 2 points and as many x, y, theta ({}, {}, {})",
            xs.len(),
            ys.len(),
            theta.len()
        )));
    }
    if let Some(v) = xs.iter().chain(ys).chain(theta).find(|v| !v.is_finite()) {
        return Err(ReportError::InvalidInput(format!(
            "the planar path has a non-finite value {v}"
        )));
    }
    let (w, h) = size;
    if !(200..=8000).contains(&w) || !(150..=8000).contains(&h) {
        return Err(ReportError::InvalidInput(format!(
            "figure size {w}x{h} outside 200x150 .. 8000x8000"
        )));
    }
    let plot_error = |message: String| ReportError::Plot {
        path: PathBuf::from("path"),
        message,
    };
    ensure_font().map_err(plot_error)?;
    // Equal scales: the data box grown to the plot area's aspect ratio.
    let (x0, x1) = padded(finite_range(xs.iter()).unwrap_or((-1.0, 1.0)));
    let (y0, y1) = padded(finite_range(ys.iter()).unwrap_or((-1.0, 1.0)));
    let aspect = f64::from(w) / f64::from(h);
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let half_w = (0.5 * (x1 - x0)).max(0.5 * (y1 - y0) * aspect);
    let half_h = half_w / aspect;
    let (xr, yr) = ((cx - half_w, cx + half_w), (cy - half_h, cy + half_h));
    let tick = 0.04 * (2.0 * half_w);
    let (sw, sh) = (w * SUPERSAMPLE, h * SUPERSAMPLE);
    let mut big = vec![0u8; sw as usize * sh as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut big, (sw, sh)).into_drawing_area();
        let f = Fonts::for_size((sw, sh));
        let draw = || -> Result<(), DrawingAreaErrorKind<_>> {
            root.fill(&WHITE)?;
            let mut chart = ChartBuilder::on(&root)
                .caption(title, (FAMILY, f.title))
                .margin(f.label)
                .x_label_area_size(3.0 * f.label)
                .y_label_area_size(4.0 * f.label)
                .build_cartesian_2d(xr.0..xr.1, yr.0..yr.1)?;
            chart
                .configure_mesh()
                .x_desc("x")
                .y_desc("y")
                .label_style((FAMILY, f.label))
                .axis_desc_style((FAMILY, f.desc))
                .draw()?;
            let line = ShapeStyle::from(&OMEGA_COLOR).stroke_width(3 * SUPERSAMPLE);
            chart
                .draw_series(LineSeries::new(
                    xs.iter().zip(ys).map(|(a, b)| (*a, *b)),
                    line,
                ))?
                .label("reference point (x, y)")
                .legend(move |(px, py)| {
                    PathElement::new(vec![(px, py), (px + 30, py)], OMEGA_COLOR)
                });
            let heading = ShapeStyle::from(&XI_COLOR).stroke_width(2 * SUPERSAMPLE);
            let ticks: Vec<PathElement<(f64, f64)>> = (0..headings.max(2))
                .map(|k| {
                    let i = k * (n - 1) / (headings.max(2) - 1);
                    let (a, b) = (xs[i], ys[i]);
                    PathElement::new(
                        vec![
                            (a, b),
                            (a + tick * theta[i].cos(), b + tick * theta[i].sin()),
                        ],
                        heading,
                    )
                })
                .collect();
            chart
                .draw_series(ticks)?
                .label("body axis e1 (heading theta)")
                .legend(move |(px, py)| PathElement::new(vec![(px, py), (px + 30, py)], XI_COLOR));
            let r = 6 * SUPERSAMPLE as i32;
            chart.draw_series([
                Circle::new((xs[0], ys[0]), r, START_COLOR.filled()),
                Circle::new((xs[n - 1], ys[n - 1]), r, END_COLOR.filled()),
            ])?;
            chart
                .configure_series_labels()
                .label_font((FAMILY, f.legend))
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()?;
            root.present()?;
            Ok(())
        };
        draw().map_err(|e| plot_error(e.to_string()))?;
    }
    encode_png(&downsample(&big, w, h, SUPERSAMPLE), w, h).map_err(plot_error)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(n: usize, f: impl Fn(f64) -> f64) -> TrajectoryTable {
        let mut tab = TrajectoryTable::default();
        for i in 0..n {
            let t = i as f64 * 0.1;
            let v = f(t);
            tab.t.push(t);
            tab.omega.push([5.0, v, 0.0]);
            tab.xi.push([0.0, 1.0 + v, 0.0]);
            tab.xi_dot.push([v; 3]);
            tab.kappa.push([v, -v, 2.0 * v]);
            tab.omega_d.push([5.0, 0.0, v]);
        }
        tab
    }

    fn opts(format: FigureFormat) -> FigureOptions {
        let e = EnergyEllipsoid::through([1.0, 2.0, 3.0], [5.0, 0.0, 0.0]).unwrap();
        FigureOptions {
            format,
            size: (400, 300),
            ..FigureOptions::new("edge case", e)
        }
    }

    /// Degenerate data must still give a figure (no panic in plotters' tick search).
    #[test]
    fn degenerate_data_render() {
        let cases: Vec<(&str, TrajectoryTable)> = vec![
            ("one row", table(1, |_| 0.3)),
            ("all zero", table(50, |_| 0.0)),
            ("constant", table(50, |_| 0.25)),
            ("tiny variation", table(50, |t| 1e-13 * t)),
            ("relative 1e-8", table(50, |t| 1.0 + 1e-8 * t)),
            ("huge", table(50, |t| 1e250 * (t - 2.0))),
            ("tiny", table(50, |t| 1e-250 * (t - 2.0))),
        ];
        for (name, tab) in cases {
            for format in [FigureFormat::Png, FigureFormat::Svg] {
                for fig in Figure::ALL {
                    let bytes = render_figure_bytes(fig, &tab, &opts(format))
                        .unwrap_or_else(|e| panic!("{name} {fig:?}: {e}"));
                    assert!(bytes.len() > 100, "{name} {fig:?}");
                }
            }
        }
    }

    /// Figures rendered side by side (as `suslov paper` and `solve` do) have the bytes of
    /// figures rendered one after the other: the renderer shares no state between threads
    /// that changes its output.
    #[test]
    fn figures_rendered_in_parallel_are_byte_identical() {
        let tab = table(200, |t| (3.0 * t).sin());
        let o = opts(FigureFormat::Png);
        let serial: Vec<Vec<u8>> = Figure::ALL
            .iter()
            .map(|&fig| render_figure_bytes(fig, &tab, &o).unwrap())
            .collect();
        let parallel: Vec<Vec<u8>> = std::thread::scope(|scope| {
            let handles: Vec<_> = Figure::ALL
                .iter()
                .map(|&fig| {
                    let (tab, o) = (&tab, &o);
                    scope.spawn(move || render_figure_bytes(fig, tab, o).unwrap())
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        assert_eq!(serial, parallel);
    }

    #[test]
    fn tick_steps_and_labels() {
        assert_eq!(tick_step(0.0, 11.36, 10), 2.0);
        assert_eq!(tick_step(0.97, 1.03, 10), 0.01);
        assert_eq!(tick_label(1.0, 0.01), "1.00");
        assert_eq!(tick_label(-1e-18, 0.5), "0.0");
        assert_eq!(tick_label(4.0, 2.0), "4");
        assert_eq!(power_of_ten(-16), "10⁻¹⁶");
        assert_eq!(power_of_ten(250), "10²⁵⁰");
        assert_eq!(display_exponent(6.6e-16), -16);
        assert_eq!(display_exponent(3.0), 0);
        assert_eq!(display_exponent(0.0), 0);
    }

    #[test]
    fn legend_goes_where_the_data_is_not() {
        let upper_right: Vec<(f64, f64)> =
            (0..100).map(|i| (0.9 + i as f64 * 1e-3, 0.95)).collect();
        assert!(matches!(
            best_legend_corner(&upper_right, 0.2, 0.2),
            (SeriesLabelPosition::LowerRight, 0)
        ));
        assert!(matches!(
            best_legend_corner(&[], 0.2, 0.2).0,
            SeriesLabelPosition::UpperRight
        ));
    }

    #[test]
    fn downsampling_averages_blocks() {
        // 2x2 image of one 2x2 block: values 0, 100, 200, 100 -> 100.
        let big = [0, 0, 0, 100, 100, 100, 200, 200, 200, 100, 100, 100];
        assert_eq!(downsample(&big, 1, 1, 2), vec![100, 100, 100]);
    }
}
