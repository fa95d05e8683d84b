//! Figures of one solved case, as in section 5.3 of the paper (figures 5.2 and 5.3).
//!
//! Drawn with `plotters`. Text is rasterised by `ab_glyph` from a font embedded in the
//! binary (a subset of DejaVu Sans, `src/report/font/`), so neither building nor running
//! needs fontconfig, freetype or any installed font: PNG output works on a bare machine.
//! PNG is the default format ([`FigureFormat::Png`]); SVG ([`FigureFormat::Svg`]) is
//! available for vector output (its text is SVG `<text>` in the viewer's sans-serif font).
//! Both are drawn by the same code, so a PNG and an SVG of one figure show the same thing.
//!
//! Every file is rendered in memory and then written with [`write_atomic`].

use super::{norm, significant, write_atomic, EnergyEllipsoid, ReportError, TrajectoryTable};
use plotters::coord::ranged3d::ProjectionMatrixBuilder;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::{CoordTranslate, Shift};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{register_font, FontStyle};
use std::f64::consts::FRAC_PI_2;
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
/// Ω_d in the 3-D view: a wide grey band drawn under Ω, so that Ω stays visible where it
/// runs along Ω_d.
const DESIRED_COLOR: RGBColor = RGBColor(170, 170, 170);
/// The reference path in the 3-D view when it is not in the cost (γ = 0): thin and dashed.
const REFERENCE_COLOR: RGBColor = RGBColor(90, 90, 90);
/// ξ_∥ in the 3-D view.
const XI_COLOR: RGBColor = RGBColor(255, 127, 14);
/// Start marker (of Ω in the 3-D view).
const START_COLOR: RGBColor = RGBColor(0, 170, 0);
/// End marker (of Ω in the 3-D view).
const END_COLOR: RGBColor = RGBColor(220, 0, 0);
/// Start marker of ξ_∥ in the 3-D view.
const XI_START_COLOR: RGBColor = RGBColor(0, 180, 190);
/// End marker of ξ_∥ in the 3-D view.
const XI_END_COLOR: RGBColor = RGBColor(190, 0, 190);
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
    /// Both formats, PNG first: `suslov solve` and `paper` write every figure in each.
    pub const ALL: [FigureFormat; 2] = [FigureFormat::Png, FigureFormat::Svg];

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
    /// `xi`: components ξ₁, ξ₂, ξ₃ of the constraint vector against t.
    Xi,
    /// `xi_dot`: components of the control ξ̇ = dξ/dt against t.
    XiDot,
}

impl Figure {
    /// All figures, in the order [`write_case_figures`] writes them.
    pub const ALL: [Figure; 7] = [
        Figure::Omega3d,
        Figure::Constraint,
        Figure::XiNorm,
        Figure::Kappa,
        Figure::OmegaComponents,
        Figure::Xi,
        Figure::XiDot,
    ];

    /// File stem: `omega_3d`, `constraint`, `xi_norm`, `kappa`, `omega`, `xi` or `xi_dot`.
    pub fn stem(self) -> &'static str {
        match self {
            Figure::Omega3d => "omega_3d",
            Figure::Constraint => "constraint",
            Figure::XiNorm => "xi_norm",
            Figure::Kappa => "kappa",
            Figure::OmegaComponents => "omega",
            Figure::Xi => "xi",
            Figure::XiDot => "xi_dot",
        }
    }
}

/// The `(yaw, pitch)` of the 3-D figure that [`choose_view_3d`] prefers among equally good
/// views (and takes when there is nothing to see).
pub const DEFAULT_VIEW_3D: (f64, f64) = (-0.5, 0.35);

/// How to draw the figures of one case.
#[derive(Debug, Clone, PartialEq)]
pub struct FigureOptions {
    /// Case name shown in every title, e.g. `"eta = 1"` (in parentheses after the figure's
    /// own title when there is no [`subtitle`](Self::subtitle)).
    pub title: String,
    /// A second title line under every figure's own title, as the paper's captions, e.g.
    /// `"eta_1: α = 1, β = 0.1, γ = 1, η = 1, δ = 0.2, b = 11.3596"` ([`case_subtitle`]).
    /// When given it replaces the case name in parentheses; `None` (the default) draws the
    /// single title line `<figure title> (<title>)`.
    pub subtitle: Option<String>,
    /// Whether Ω_d is in the cost (its weight γ > 0). When `false` it is not drawn as the
    /// "desired" path: the figures call it the reference path, not in the cost (in the 3-D
    /// view: thin and dashed). Default `true`.
    pub desired_in_cost: bool,
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
    /// turns about the vertical Ω₃ axis, pitch tilts towards a view from above), or `None`
    /// (the default): chosen from the data by [`choose_view_3d`].
    pub view_3d: Option<(f64, f64)>,
}

impl FigureOptions {
    /// PNG, 1200 × 900 pixels, no subtitle, Ω_d in the cost, no extended Ω_d, the 3-D view
    /// chosen from the data.
    pub fn new(title: impl Into<String>, ellipsoid: EnergyEllipsoid) -> Self {
        Self {
            title: title.into(),
            subtitle: None,
            desired_in_cost: true,
            ellipsoid,
            format: FigureFormat::Png,
            size: (1200, 900),
            desired_extended: None,
            view_3d: None,
        }
    }
}

/// The second title line of a case's figures ([`FigureOptions::subtitle`]), as the paper's
/// captions: `"<case>: <symbol> = <value>, …, b = <terminal time>"`, every value with six
/// significant digits ([`significant`]), e.g. `"eta_1: α = 1, β = 0.1, γ = 1, η = 1, δ = 0.2,
/// b = 11.3596"`.
pub fn case_subtitle(case: &str, weights: &[(&str, f64)], terminal_time: f64) -> String {
    let mut parts: Vec<String> = weights
        .iter()
        .map(|(symbol, v)| format!("{symbol} = {}", significant(*v, 6)))
        .collect();
    parts.push(format!("b = {}", significant(terminal_time, 6)));
    format!("{case}: {}", parts.join(", "))
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
    let bytes = render_figure(figure, table, opts, &mut Vec::new()).map_err(|message| {
        ReportError::Plot {
            path: path.to_path_buf(),
            message,
        }
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
    render_figure_bytes_in(figure, table, opts, &mut Vec::new())
}

/// [`render_figure_bytes`] drawing PNGs in the caller's `canvas` (resized as needed; its
/// contents do not matter, every figure paints its background first). A renderer that
/// draws many figures keeps one canvas: a fresh supersampled bitmap is tens of megabytes of
/// pages the kernel must zero, which measured as the largest single cost of `suslov paper`.
///
/// # Errors
/// As [`render_figure_bytes`].
pub fn render_figure_bytes_in(
    figure: Figure,
    table: &TrajectoryTable,
    opts: &FigureOptions,
    canvas: &mut Vec<u8>,
) -> Result<Vec<u8>, ReportError> {
    check_inputs(table, opts)?;
    render_figure(figure, table, opts, canvas).map_err(|message| ReportError::Plot {
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
    canvas: &mut Vec<u8>,
) -> Result<Vec<u8>, String> {
    ensure_font()?;
    let (w, h) = opts.size;
    match opts.format {
        FigureFormat::Png => {
            // Drawn at SUPERSAMPLE times the size and averaged down: plotters' bitmap lines
            // are not anti-aliased.
            let (sw, sh) = (w * SUPERSAMPLE, h * SUPERSAMPLE);
            canvas.resize(sw as usize * sh as usize * 3, 0);
            {
                let root = BitMapBackend::with_buffer(canvas, (sw, sh)).into_drawing_area();
                draw(&root, figure, table, opts)?;
                root.present().map_err(|e| e.to_string())?;
            }
            encode_png(&downsample(canvas, w, h, SUPERSAMPLE), w, h)
        }
        FigureFormat::Svg => {
            let mut svg = String::new();
            {
                let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
                draw(&root, figure, table, opts)?;
                root.present().map_err(|e| e.to_string())?;
            }
            Ok(round_joins(&svg).into_bytes())
        }
    }
}

/// Every `<polyline>` of plotters' SVG with round joins and caps: SVG's default miter join
/// draws a spike at every sharp turn of a wide line (the Ω_d band of the 3-D view turned
/// into a jagged ribbon); plotters has no option for it. The bitmap backend draws its wide
/// lines segment by segment with discs at the joints (`draw_polyline!`), the same look.
fn round_joins(svg: &str) -> String {
    svg.replace(
        "<polyline ",
        "<polyline stroke-linejoin=\"round\" stroke-linecap=\"round\" ",
    )
}

/// Supersampling factor of PNG rendering.
const SUPERSAMPLE: u32 = 2;

/// Box-filters an RGB image of size `(w·k) × (h·k)` down to `w × h`.
fn downsample(big: &[u8], w: u32, h: u32, k: u32) -> Vec<u8> {
    let (w, h, k) = (w as usize, h as usize, k as usize);
    let big_w = w * k;
    let mut out = vec![0u8; w * h * 3];
    if k == 2 {
        // The same rounded means, a row pair at a time: first the two rows summed byte by
        // byte (contiguous, so it vectorizes), then each pixel pair of that sum.
        let mut pair = vec![0u16; big_w * 3];
        for (y, orow) in out.chunks_exact_mut(w * 3).enumerate() {
            let top = &big[2 * y * big_w * 3..(2 * y + 1) * big_w * 3];
            let bottom = &big[(2 * y + 1) * big_w * 3..(2 * y + 2) * big_w * 3];
            for ((s, t), b) in pair.iter_mut().zip(top).zip(bottom) {
                *s = u16::from(*t) + u16::from(*b);
            }
            for (o, s) in orow.chunks_exact_mut(3).zip(pair.chunks_exact(6)) {
                for c in 0..3 {
                    o[c] = ((s[c] + s[3 + c] + 2) / 4) as u8;
                }
            }
        }
        return out;
    }
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
    subtitle: f64,
    desc: f64,
    label: f64,
    legend: f64,
}

impl Fonts {
    fn for_size((_, h): (u32, u32)) -> Self {
        let s = f64::from(h) / 900.0;
        Self {
            title: 34.0 * s,
            subtitle: 26.0 * s,
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
    // The three components of a column of 3-vectors, as curves against t.
    let components = |rows: &[[f64; 3]]| -> [Vec<f64>; 3] {
        [0, 1, 2].map(|k| rows.iter().map(|v| v[k]).collect())
    };
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
                opts,
                TimePlot {
                    what: "Constraint ⟨Ω, ξ⟩",
                    // The grid is named: the run's summary takes the same maximum on the
                    // checks' finer grid, and says so too.
                    suffix: format!(
                        "; max |⟨Ω, ξ⟩| = {max:.2e} on these {} points",
                        table.t.len()
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
                opts,
                TimePlot {
                    what: "Magnitude of the control vector |ξ|",
                    suffix: String::new(),
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
        Figure::Kappa | Figure::Xi | Figure::XiDot => {
            let (rows, names, what, y_desc, end_markers) = match figure {
                Figure::Kappa => (&table.kappa, ["κ₁", "κ₂", "κ₃"], "Costates κ(t)", "κ", true),
                Figure::Xi => (
                    &table.xi,
                    ["ξ₁", "ξ₂", "ξ₃"],
                    "Control vector ξ(t)",
                    "ξ",
                    false,
                ),
                _ => (
                    &table.xi_dot,
                    ["dξ₁/dt", "dξ₂/dt", "dξ₃/dt"],
                    "Rate of the control vector: u = dξ/dt",
                    "dξ/dt",
                    false,
                ),
            };
            let cols = components(rows);
            let series: Vec<Series> = (0..3)
                .map(|k| Series::new(names[k], COMPONENT_COLORS[k], &table.t, &cols[k]))
                .collect();
            draw_time_series(
                root,
                opts,
                TimePlot {
                    what,
                    suffix: String::new(),
                    y_desc,
                    series: &series,
                    y_axis: YAxis::Auto,
                    end_markers,
                    reference: None,
                    dashed_note: None,
                    segmented,
                },
            )
        }
        Figure::OmegaComponents => {
            let om = components(&table.omega);
            let od = components(&table.omega_d);
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
            let (what, note) = if opts.desired_in_cost {
                ("Body angular velocity Ω and desired Ω_d", "dashed: Ω_d")
            } else {
                (
                    "Body angular velocity Ω",
                    "dashed: reference path (not in the cost)",
                )
            };
            draw_time_series(
                root,
                opts,
                TimePlot {
                    what,
                    suffix: String::new(),
                    y_desc: "Ω",
                    series: &series,
                    y_axis: YAxis::Auto,
                    end_markers: false,
                    reference: None,
                    dashed_note: Some(note),
                    segmented,
                },
            )
        }
    };
    result.map_err(|e| e.to_string())
}

/// Where a chart goes, and the caption plotters draws above it. Without a subtitle: all of
/// `root`, caption `<what> (<case>)<suffix>` (the figures as they were before subtitles,
/// byte for byte). With one: `<what><suffix>` and the subtitle on two lines, drawn here
/// `top_margin` below the top, and the area under them with no caption.
#[allow(clippy::type_complexity)]
fn title_area<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    what: &str,
    suffix: &str,
    opts: &FigureOptions,
    top_margin: u32,
) -> Result<(DrawingArea<DB, Shift>, Option<String>), DrawingAreaErrorKind<DB::ErrorType>> {
    let Some(subtitle) = &opts.subtitle else {
        return Ok((
            root.clone(),
            Some(format!("{what} ({}){suffix}", opts.title)),
        ));
    };
    let f = Fonts::for_size(root.dim_in_pixel());
    let area = root
        .margin(top_margin, 0, 0, 0)
        .titled(&format!("{what}{suffix}"), (FAMILY, f.title))?
        .titled(subtitle, (FAMILY, f.subtitle))?;
    Ok((area, None))
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
    /// The figure's own title (the case name or subtitle is added, [`title_area`]).
    what: &'a str,
    /// Text after the title (and after the case name when there is no subtitle).
    suffix: String,
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
    opts: &FigureOptions,
    plot: TimePlot,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let TimePlot {
        what,
        suffix,
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
    let subtitle_h = if opts.subtitle.is_some() {
        1.2 * f.subtitle + 30.0 * hs
    } else {
        0.0
    };
    let plot_h_est = (f64::from(root_h) - 150.0 * hs - subtitle_h).max(1.0);
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
        // Nor the dashed reference line (e.g. |ξ| = 1): it is sampled like a curve.
        if let Some((v, _)) = reference {
            pts.extend((0..=200).map(|k| {
                let t = t0 + (t1 - t0) * f64::from(k) / 200.0;
                to_unit((t, v / unit))
            }));
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

    let margin = (20.0 * hs) as u32;
    let (area, caption) = title_area(root, what, &suffix, opts, margin)?;
    let mut builder = ChartBuilder::on(&area);
    if let Some(caption) = &caption {
        builder.caption(caption, (FAMILY, f.title));
    }
    let mut chart = builder
        .margin(margin)
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

/// Screen position (x to the right, y down; arbitrary scale and origin) of a point in chart
/// coordinates under a view `(yaw, pitch)`: plotters' own projection matrix.
fn project(view: (f64, f64), p: (f64, f64, f64)) -> (f64, f64) {
    let mut pb = ProjectionMatrixBuilder::new();
    pb.yaw = view.0;
    pb.pitch = view.1;
    let m = pb.into_matrix();
    let m: &[[f64; 4]; 4] = m.as_ref();
    (
        m[0][0] * p.0 + m[0][1] * p.1 + m[0][2] * p.2,
        m[1][0] * p.0 + m[1][1] * p.1 + m[1][2] * p.2,
    )
}

/// Width and height on screen of a cube of side 1 seen in `view`.
fn cube_extent(view: (f64, f64)) -> (f64, f64) {
    let corners = (0..8).map(|k| {
        let c = |bit: u32| if k & (1 << bit) == 0 { -0.5 } else { 0.5 };
        project(view, (c(0), c(1), c(2)))
    });
    let (mut x, mut y) = ((f64::MAX, f64::MIN), (f64::MAX, f64::MIN));
    for (a, b) in corners {
        x = (x.0.min(a), x.1.max(a));
        y = (y.0.min(b), y.1.max(b));
    }
    (x.1 - x.0, y.1 - y.0)
}

/// Pitches tried by [`choose_view_3d`] (radians; 0 is a view from the side).
const VIEW_PITCHES: [f64; 4] = [0.15, 0.3, 0.45, 0.6];

/// Yaws tried by [`choose_view_3d`] in each quadrant, in degrees from a coordinate axis:
/// nearer to an axis, the box is seen face on and two of its axes fall on one line.
const VIEW_YAWS: &[f64] = &[20.0, 30.0, 40.0, 50.0, 60.0, 70.0];

/// The view `(yaw, pitch)` of the 3-D figure chosen from the data: among the yaws 20°, 30°,
/// …, 70° away from each coordinate axis and the pitches 0.15, 0.3, 0.45 and 0.6, the one whose screen shows the marked points
/// (`markers`, body coordinates, e.g. Ω(a), Ω(b), ξ_∥(a), ξ_∥(b)) and the origin, where
/// the coordinate axes meet, farthest apart (the smallest distance between two of them is
/// the largest), plus half the spread of the curves (`curves`: how wide they look across
/// their main direction on screen, so that a curve is not seen edge-on). Markers that
/// coincide in space count once. [`DEFAULT_VIEW_3D`] is kept unless another view is
/// better, and is the answer when there is nothing finite to show.
pub fn choose_view_3d(markers: &[[f64; 3]], curves: &[&[[f64; 3]]]) -> (f64, f64) {
    let finite = |p: &&[f64; 3]| p.iter().all(|c| c.is_finite());
    let scale = markers
        .iter()
        .chain(curves.iter().flat_map(|c| c.iter()))
        .filter(finite)
        .fold(0.0f64, |m, &p| m.max(norm(p)));
    if !(scale > 0.0 && scale.is_finite()) {
        return DEFAULT_VIEW_3D;
    }
    let unit = |p: [f64; 3]| {
        let (x, y, z) = to_chart(p);
        (x / scale, y / scale, z / scale)
    };
    let dist = |a: [f64; 3], b: [f64; 3]| norm([a[0] - b[0], a[1] - b[1], a[2] - b[2]]);
    let mut points = vec![[0.0; 3]];
    for &m in markers.iter().filter(finite) {
        if points.iter().all(|&p| dist(p, m) > 0.02 * scale) {
            points.push(m);
        }
    }
    let points: Vec<(f64, f64, f64)> = points.into_iter().map(unit).collect();
    let samples: Vec<Vec<(f64, f64, f64)>> = curves
        .iter()
        .map(|c| {
            c.iter()
                .step_by((c.len() / 200).max(1))
                .filter(finite)
                .map(|&p| unit(p))
                .collect::<Vec<_>>()
        })
        .filter(|c| c.len() > 1)
        .collect();
    let score = |view: (f64, f64)| {
        let screen: Vec<(f64, f64)> = points.iter().map(|&p| project(view, p)).collect();
        let mut nearest = f64::INFINITY;
        for (i, a) in screen.iter().enumerate() {
            for b in &screen[i + 1..] {
                nearest = nearest.min((a.0 - b.0).hypot(a.1 - b.1));
            }
        }
        if !nearest.is_finite() {
            nearest = 0.0;
        }
        let spread = samples
            .iter()
            .map(|c| {
                // The smaller principal standard deviation of the projected curve.
                let s: Vec<(f64, f64)> = c.iter().map(|&p| project(view, p)).collect();
                let n = s.len() as f64;
                let (mx, my) = s
                    .iter()
                    .fold((0.0, 0.0), |(a, b), p| (a + p.0 / n, b + p.1 / n));
                let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
                for p in &s {
                    let (dx, dy) = (p.0 - mx, p.1 - my);
                    sxx += dx * dx / n;
                    syy += dy * dy / n;
                    sxy += dx * dy / n;
                }
                let half_trace = 0.5 * (sxx + syy);
                let det = sxx * syy - sxy * sxy;
                (half_trace - (half_trace * half_trace - det).max(0.0).sqrt())
                    .max(0.0)
                    .sqrt()
            })
            .sum::<f64>()
            / samples.len().max(1) as f64;
        nearest + 0.5 * spread
    };
    let mut best = (DEFAULT_VIEW_3D, score(DEFAULT_VIEW_3D));
    for quadrant in -2..2 {
        for &degrees in VIEW_YAWS {
            let yaw = f64::from(quadrant) * FRAC_PI_2 + degrees.to_radians();
            for pitch in VIEW_PITCHES {
                let s = score((yaw, pitch));
                if s > best.1 + 1e-9 {
                    best = ((yaw, pitch), s);
                }
            }
        }
    }
    best.0
}

/// The sample drawn before an entry of the 3-D figure's legend.
#[derive(Clone, Copy)]
enum Sample {
    /// A line of this colour and width.
    Line(RGBColor, u32),
    /// A dashed line of this colour and width.
    Dashed(RGBColor, u32),
    /// A filled circle.
    Circle(RGBColor),
    /// A filled triangle.
    Triangle(RGBColor),
    /// None: the text continues the entry above.
    Note,
}

/// Draws the legend of the 3-D figure in its own column `area`: a framed list of entries at
/// the top.
fn draw_legend_column<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[(Sample, String)],
    (f, hs): (&Fonts, f64),
    (sample_len, marker): (i32, i32),
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let (w, _) = area.dim_in_pixel();
    let line_h = (1.35 * f.legend).round() as i32;
    let pad = (12.0 * hs) as i32;
    let top = (30.0 * hs) as i32;
    let height = pad * 2 + line_h * entries.len() as i32;
    area.draw(&Rectangle::new(
        [(0, top), (w as i32 - 1, top + height)],
        WHITE.mix(0.9).filled(),
    ))?;
    area.draw(&Rectangle::new(
        [(0, top), (w as i32 - 1, top + height)],
        BLACK.mix(0.4),
    ))?;
    let text_x = pad + sample_len + pad;
    for (i, (sample, text)) in entries.iter().enumerate() {
        let y = top + pad + line_h * i as i32 + line_h / 2;
        let (x0, x1) = (pad, pad + sample_len);
        let mid = (x0 + x1) / 2;
        match *sample {
            Sample::Line(color, width) => {
                area.draw(&PathElement::new(
                    vec![(x0, y), (x1, y)],
                    color.stroke_width(width),
                ))?;
            }
            Sample::Dashed(color, width) => {
                let d = sample_len * 3 / 10;
                for k in 0..2 {
                    let a = x0 + k * (sample_len - d);
                    area.draw(&PathElement::new(
                        vec![(a, y), (a + d, y)],
                        color.stroke_width(width),
                    ))?;
                }
            }
            Sample::Circle(color) => {
                let r = marker_radius(color, marker);
                area.draw(&Circle::new((mid, y), r, color.filled()))?;
            }
            Sample::Triangle(color) => {
                let size = triangle_size(marker_radius(color, marker));
                area.draw(&TriangleMarker::new((mid, y), size, color.filled()))?;
            }
            Sample::Note => {}
        }
        let style = (FAMILY, f.legend)
            .into_font()
            .color(&if matches!(sample, Sample::Note) {
                BLACK.mix(0.7)
            } else {
                BLACK.mix(1.0)
            })
            .pos(Pos::new(HPos::Left, VPos::Center));
        area.draw(&Text::new(text.clone(), (text_x, y), style))?;
    }
    Ok(())
}

/// Radius of a marker of the 3-D figure: start markers (drawn first) are larger than the
/// others, `r`.
fn marker_radius(color: RGBColor, r: i32) -> i32 {
    if color == START_COLOR || color == XI_START_COLOR {
        r * 3 / 2
    } else {
        r
    }
}

/// Size of a triangle marker that looks as large as a circle of radius `r`.
fn triangle_size(r: i32) -> i32 {
    r * 13 / 10
}

/// The 3-D chart of [`draw_omega_3d`].
type Chart3d<'a, DB> = ChartContext<
    'a,
    DB,
    plotters::coord::cartesian::Cartesian3d<RangedCoordf64, RangedCoordf64, RangedCoordf64>,
>;

/// Writes the names Ω₁, Ω₂, Ω₃ next to the box edges that carry plotters' tick labels,
/// beyond the labels: the edge is found as plotters finds it (the axis panels and edge
/// choice of its `configure_axes().draw()`, by projected depth), the side as plotters puts
/// the labels (away from the centre, across the edge), `tick` being the tick size and
/// `label` the size of the widest tick label.
fn draw_axis_names<DB: DrawingBackend>(
    chart: &Chart3d<'_, DB>,
    r: f64,
    tick: i32,
    label: (u32, u32),
    font: f64,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let coord = chart.as_coord_spec();
    let depth = |v: [f64; 3]| coord.projected_depth(&v[0], &v[1], &v[2]);
    let px = |v: [f64; 3]| coord.translate(&(v[0], v[1], v[2]));
    let (lo, hi) = ([-r; 3], [r; 3]);
    // The panel of each axis: at its low or high end, whichever is farther from the viewer.
    let fixed: [f64; 3] = std::array::from_fn(|i| {
        let mut c = lo;
        c[i] = hi[i];
        if depth(lo) >= depth(c) {
            lo[i]
        } else {
            hi[i]
        }
    });
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    let (x_mid, y_mid) = ((xr.start + xr.end) / 2, (yr.start + yr.end) / 2);
    // Chart axes x, y, z are Ω₂, Ω₃, Ω₁ (`to_chart`).
    let names = ["Ω₂", "Ω₃", "Ω₁"];
    for (idx, name) in names.iter().enumerate() {
        let mut plan = Vec::with_capacity(4);
        for i in (0..3).filter(|&i| i != idx) {
            let j = 3 - i - idx;
            for jv in [lo[j], hi[j]] {
                let mut s = lo;
                s[i] = fixed[i];
                s[j] = jv;
                let mut e = s;
                e[idx] = hi[idx];
                plan.push((s, e));
            }
        }
        let Some(&(s, e)) = plan
            .iter()
            .min_by_key(|&&(s, e)| (depth(s) + depth(e), px(s).1 + px(e).1))
        else {
            continue;
        };
        let (b, en) = (px(s), px(e));
        let axis_dir = (en.0 - b.0, en.1 - b.1);
        // plotters' label side: horizontal or vertical, away from the centre, whichever is
        // more across the edge.
        let x_dir = if b.0 < x_mid { -1.0 } else { 1.0 };
        let y_dir = if b.1 < y_mid { -1.0 } else { 1.0 };
        let horizontal =
            (x_dir * f64::from(axis_dir.0)).abs() < (y_dir * f64::from(axis_dir.1)).abs();
        let dir = if horizontal {
            (x_dir, 0.0)
        } else {
            (0.0, y_dir)
        };
        // The unit normal of the edge on the labels' side, and how far along it the tick
        // labels reach (their boxes: 2 ticks out along `dir`, anchored at the near side).
        let len = f64::from(axis_dir.0).hypot(f64::from(axis_dir.1)).max(1.0);
        let mut n = (-f64::from(axis_dir.1) / len, f64::from(axis_dir.0) / len);
        if n.0 * dir.0 + n.1 * dir.1 < 0.0 {
            n = (-n.0, -n.1);
        }
        let t = f64::from(tick);
        let (lw, lh) = (f64::from(label.0), f64::from(label.1));
        let reach = if horizontal {
            n.0.abs() * (2.0 * t + lw) + n.1.abs() * lh / 2.0
        } else {
            n.0.abs() * lw / 2.0 + n.1.abs() * (2.0 * t + lh)
        };
        let style = (FAMILY, font)
            .into_font()
            .color(&BLACK)
            .pos(Pos::new(HPos::Center, VPos::Center));
        let (nw, nh) = chart
            .plotting_area()
            .estimate_text_size(name, &style)
            .unwrap_or((0, 0));
        // A gap of a label's height clear of the labels' band.
        let d = reach + lh + n.0.abs() * f64::from(nw) / 2.0 + n.1.abs() * f64::from(nh) / 2.0;
        let mut m = s;
        m[idx] = 0.5 * (lo[idx] + hi[idx]);
        let (mx, my) = px(m);
        let pos = (mx + (n.0 * d).round() as i32, my + (n.1 * d).round() as i32);
        // `translate` gives backend pixels: draw in screen coordinates.
        chart
            .plotting_area()
            .use_screen_coord()
            .draw(&Text::new(name.to_string(), pos, style))?;
    }
    Ok(())
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
    let finite = |v: &[f64; 3]| v.iter().all(|c| c.is_finite());
    let omega: Vec<[f64; 3]> = table.omega.iter().copied().filter(finite).collect();
    let desired: Vec<[f64; 3]> = opts
        .desired_extended
        .as_deref()
        .unwrap_or(&table.omega_d)
        .iter()
        .copied()
        .filter(finite)
        .collect();
    let xi_par: Vec<[f64; 3]> = table.xi_par(e).into_iter().flatten().collect();
    // Ω_d(b), marked when Ω_d is drawn beyond b.
    let desired_b = opts
        .desired_extended
        .as_ref()
        .and_then(|_| table.omega_d.iter().rev().copied().find(finite));

    // One cube for all axes so that the ellipsoid keeps its true shape.
    let data_max = omega
        .iter()
        .chain(&desired)
        .chain(&xi_par)
        .flat_map(|v| v.iter())
        .fold(0.0f64, |m, c| m.max(c.abs()));
    let r = 1.08 * e.semi_axes().iter().fold(data_max, |m, &a| m.max(a));

    // Markers (point, shape and colour, legend text), in the legend's order: Ω(a), Ω(b),
    // ξ_∥(a), ξ_∥(b), Ω_d(b).
    let desired_b_label = if opts.desired_in_cost {
        "Ω_d(b)"
    } else {
        "reference path at b"
    };
    let markers: Vec<([f64; 3], Sample, &str)> = [
        (omega.first(), Sample::Circle(START_COLOR), "Ω(a), start"),
        (omega.last(), Sample::Circle(END_COLOR), "Ω(b), end"),
        (
            xi_par.first(),
            Sample::Triangle(XI_START_COLOR),
            "ξ_∥(a), start",
        ),
        (xi_par.last(), Sample::Triangle(XI_END_COLOR), "ξ_∥(b), end"),
        (
            desired_b.as_ref(),
            Sample::Circle(YELLOW_MARKER),
            desired_b_label,
        ),
    ]
    .into_iter()
    .filter_map(|(p, sample, text)| Some((*p?, sample, text)))
    .collect();
    let view = opts.view_3d.unwrap_or_else(|| {
        let points: Vec<[f64; 3]> = markers.iter().map(|m| m.0).collect();
        choose_view_3d(&points, &[&omega, &xi_par])
    });

    let rad = (7.0 * hs).max(2.0) as i32;
    // Curves, drawn in this order: Ω last, on top (it stays visible where it runs along
    // Ω_d, drawn as a wider band under it).
    let width = (2.5 * hs).max(1.0) as u32;
    let band = (8.0 * hs).max(3.0) as u32;
    let thin = (1.5 * hs).max(1.0) as u32;
    let desired_sample = if opts.desired_in_cost {
        Sample::Line(DESIRED_COLOR, band)
    } else {
        Sample::Dashed(REFERENCE_COLOR, thin)
    };
    let mut legend: Vec<(Sample, String)> =
        vec![(Sample::Line(OMEGA_COLOR, width), "Ω (optimal)".into())];
    if opts.desired_in_cost {
        legend.push((desired_sample, "Ω_d (desired)".into()));
    } else {
        legend.push((desired_sample, "reference path".into()));
        legend.push((Sample::Note, "(not in the cost)".into()));
    }
    legend.push((Sample::Line(XI_COLOR, width), "ξ_∥ (control, on E)".into()));
    legend.extend(
        markers
            .iter()
            .map(|(_, sample, text)| (*sample, text.to_string())),
    );

    // Layout: the title lines, then the chart with the legend in a column at its right.
    let margin = (10.0 * hs) as u32;
    let what = if opts.desired_in_cost {
        "Ω, Ω_d and ξ_∥ on the energy ellipsoid E"
    } else {
        "Ω and ξ_∥ on the energy ellipsoid E"
    };
    let area = match title_area(root, what, "", opts, margin)? {
        (area, Some(caption)) => area
            .margin(margin, 0, 0, 0)
            .titled(&caption, (FAMILY, f.title))?,
        (area, None) => area,
    };
    let legend_font: TextStyle = (FAMILY, f.legend).into();
    let text_w = legend
        .iter()
        .map(|(_, t)| area.estimate_text_size(t, &legend_font).map_or(0, |s| s.0))
        .max()
        .unwrap_or(0);
    let sample_len = (40.0 * hs) as i32;
    let legend_w = (text_w as i32 + sample_len + (36.0 * hs) as i32).max(1) as u32;
    let (area_w, _) = area.dim_in_pixel();
    let split = area_w.saturating_sub(legend_w + margin).max(area_w / 2);
    let (chart_area, legend_area) = area.split_horizontally(split);
    let legend_area = legend_area.margin(0, 0, 0, margin);

    let mut chart = ChartBuilder::on(&chart_area)
        .margin(margin)
        .build_cartesian_3d(-r..r, -r..r, -r..r)?;
    // As large as fits with room for the tick labels and axis names around the box.
    let (pw, ph) = chart.plotting_area().dim_in_pixel();
    let coord_size = f64::from(pw.min(ph) * 4 / 5).max(1.0);
    let (cw, ch) = cube_extent(view);
    let room = (f64::from(pw) - 180.0 * hs, f64::from(ph) - 120.0 * hs);
    let scale = (room.0 / (coord_size * cw))
        .min(room.1 / (coord_size * ch))
        .clamp(0.3, 0.9);
    chart.with_projection(|mut pb| {
        pb.yaw = view.0;
        pb.pitch = view.1;
        pb.scale = scale;
        pb.into_matrix()
    });
    let label_fmt = |v: &f64| format!("{v:.0}");
    let tick = (6.0 * hs).max(2.0) as i32;
    chart
        .configure_axes()
        .label_style((FAMILY, f.label))
        .tick_size(tick)
        .light_grid_style(BLACK.mix(0.05))
        .bold_grid_style(BLACK.mix(0.12))
        .max_light_lines(1)
        .x_formatter(&label_fmt)
        .y_formatter(&label_fmt)
        .z_formatter(&label_fmt)
        .draw()?;
    let widest = root
        .estimate_text_size(&label_fmt(&-r.abs().floor()), &(FAMILY, f.label).into())
        .unwrap_or((0, 0));
    draw_axis_names(&chart, r, tick, widest, f.desc)?;

    // Wireframe of E and the coordinate axes through the origin.
    let wire = BLACK.mix(0.13).stroke_width(1);
    for line in ellipsoid_wireframe(e, 7, 12) {
        chart.draw_series(LineSeries::new(line.into_iter().map(to_chart), wire))?;
    }
    let axis_style = BLACK.mix(0.45).stroke_width(1);
    for k in 0..3 {
        let mut lo = [0.0; 3];
        let mut hi = [0.0; 3];
        lo[k] = -r;
        hi[k] = r;
        chart.draw_series(LineSeries::new([to_chart(lo), to_chart(hi)], axis_style))?;
    }

    let thinned = |pts: &[[f64; 3]]| -> Vec<(f64, f64, f64)> {
        thin_out(pts, 0.006 * r, |a, b| {
            norm([a[0] - b[0], a[1] - b[1], a[2] - b[2]])
        })
        .into_iter()
        .map(to_chart)
        .collect()
    };
    let desired_pts = thinned(&desired);
    if opts.desired_in_cost {
        draw_polyline!(chart, &desired_pts, DESIRED_COLOR, band, segmented);
    } else {
        let dash = (12.0 * hs) as u32;
        chart.draw_series(DashedLineSeries::new(
            desired_pts,
            dash,
            dash * 2 / 3,
            REFERENCE_COLOR.stroke_width(thin),
        ))?;
    }
    draw_polyline!(chart, &thinned(&xi_par), XI_COLOR, width, segmented);
    draw_polyline!(chart, &thinned(&omega), OMEGA_COLOR, width, segmented);

    // ξ_∥'s markers under Ω's, Ω_d(b) on top; a start marker is larger than the end marker
    // drawn over it, so that both show when a curve ends where it began.
    let (circles, triangles): (Vec<_>, Vec<_>) = markers
        .iter()
        .partition(|m| matches!(m.1, Sample::Circle(_)));
    for (p, sample, _) in triangles.into_iter().chain(circles) {
        let p = to_chart(p);
        match sample {
            Sample::Triangle(color) => {
                let size = triangle_size(marker_radius(color, rad));
                chart.draw_series(std::iter::once(TriangleMarker::new(
                    p,
                    size,
                    color.filled(),
                )))?;
            }
            Sample::Circle(color) => {
                let r = marker_radius(color, rad);
                chart.draw_series(std::iter::once(Circle::new(p, r, color.filled())))?;
            }
            _ => {}
        }
    }
    draw_legend_column(&legend_area, &legend, (&f, hs), (sample_len, rad))
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
            for format in FigureFormat::ALL {
                // As `suslov` draws them too: a subtitle, and Ω_d not in the cost.
                let mut plain = opts(format);
                plain.desired_extended = Some(tab.omega_d.clone());
                let styled = FigureOptions {
                    subtitle: Some("case: α = 1, b = 2".into()),
                    desired_in_cost: false,
                    ..plain.clone()
                };
                for o in [plain, styled] {
                    for fig in Figure::ALL {
                        let bytes = render_figure_bytes(fig, &tab, &o)
                            .unwrap_or_else(|e| panic!("{name} {fig:?}: {e}"));
                        assert!(bytes.len() > 100, "{name} {fig:?}");
                    }
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

    /// The smallest screen distance between the origin and the distinct markers.
    fn nearest(view: (f64, f64), markers: &[[f64; 3]]) -> f64 {
        let pts: Vec<(f64, f64)> = std::iter::once([0.0; 3])
            .chain(markers.iter().copied())
            .map(|p| project(view, to_chart(p)))
            .collect();
        let mut d = f64::INFINITY;
        for (i, a) in pts.iter().enumerate() {
            for b in &pts[i + 1..] {
                d = d.min((a.0 - b.0).hypot(a.1 - b.1));
            }
        }
        d
    }

    #[test]
    fn the_chosen_view_separates_the_markers() {
        // The paper's η = 1 case: Ω(a) on the Ω₁ axis, the spiral about it.
        let markers = [
            [5.0, 0.0, 0.0],
            [2.75, -2.3, -1.5],
            [-1.0, 2.0, 2.0],
            [0.5, -2.5, 1.5],
        ];
        let spiral: Vec<[f64; 3]> = (0..500)
            .map(|i| {
                let s = f64::from(i) / 499.0;
                let (a, b) = (12.0 * s).sin_cos();
                [5.0 - 2.0 * s, 3.0 * s * a, 2.5 * s * b]
            })
            .collect();
        let view = choose_view_3d(&markers, &[&spiral]);
        assert!(nearest(view, &markers) >= nearest(DEFAULT_VIEW_3D, &markers));
        assert!(nearest(view, &markers) > 0.15 * 5.0, "{view:?}");
        // Never face on: 20° .. 70° from the coordinate axes.
        let from_axis = view.0.rem_euclid(FRAC_PI_2).to_degrees();
        assert!((19.9..=70.1).contains(&from_axis), "{view:?}");
        // Nothing finite to show: the default view.
        assert_eq!(choose_view_3d(&[], &[]), DEFAULT_VIEW_3D);
        assert_eq!(choose_view_3d(&[[f64::NAN; 3]], &[]), DEFAULT_VIEW_3D);
        // Markers that coincide count once (and do not force a zero distance).
        let twice = [markers[0], markers[0], markers[1]];
        assert!(nearest(choose_view_3d(&twice, &[]), &twice[1..]) > 0.0);
    }

    #[test]
    fn subtitles_and_formats() {
        assert_eq!(
            case_subtitle("eta_0.01", &[("α", 1.0), ("η", 0.01)], 9.8383264),
            "eta_0.01: α = 1, η = 0.01, b = 9.83833"
        );
        assert_eq!(
            FigureFormat::ALL.map(FigureFormat::extension),
            ["png", "svg"]
        );
        let stems: Vec<&str> = Figure::ALL.iter().map(|f| f.stem()).collect();
        assert_eq!(
            stems,
            [
                "omega_3d",
                "constraint",
                "xi_norm",
                "kappa",
                "omega",
                "xi",
                "xi_dot"
            ]
        );
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

    /// The row-pair path of `k = 2` gives the rounded block means of the definition, on a
    /// pseudo-random image (every byte value, rounding up and down, odd widths).
    #[test]
    fn downsampling_by_two_is_the_rounded_block_mean() {
        let (w, h) = (7usize, 5usize);
        let mut state = 0x2545_f491_u32;
        let big: Vec<u8> = (0..(2 * w) * (2 * h) * 3)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                (state >> 24) as u8
            })
            .collect();
        let out = downsample(&big, w as u32, h as u32, 2);
        for y in 0..h {
            for x in 0..w {
                for c in 0..3 {
                    let at = |yy: usize, xx: usize| u32::from(big[(yy * 2 * w + xx) * 3 + c]);
                    let sum = at(2 * y, 2 * x)
                        + at(2 * y, 2 * x + 1)
                        + at(2 * y + 1, 2 * x)
                        + at(2 * y + 1, 2 * x + 1);
                    assert_eq!(u32::from(out[(y * w + x) * 3 + c]), (sum + 2) / 4);
                }
            }
        }
    }
}
