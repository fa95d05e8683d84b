//! Figures (issue #14): every figure as PNG and SVG, titles with the weights and b, the
//! figures of ξ and ξ̇, and γ = 0 (Ω_d not in the cost) never drawn as "desired".
//!
//! The SVGs are checked with a small well-formedness checker of XML (below): one root
//! element, every element closed in order, attributes quoted and unique, entities valid.

use std::path::{Path, PathBuf};
use suslov::report::{
    case_subtitle, render_figure_bytes, EnergyEllipsoid, Figure, FigureFormat, FigureOptions,
    Summary, TrajectoryTable,
};

/// Checks that `s` is well-formed XML and returns the contents of its `<text>` elements,
/// entities decoded, without the white space around them.
fn xml_texts(s: &str) -> Result<Vec<String>, String> {
    fn decode(raw: &str) -> Result<String, String> {
        let mut out = String::new();
        let mut rest = raw;
        while let Some(i) = rest.find('&') {
            out.push_str(&rest[..i]);
            let end = rest[i..]
                .find(';')
                .ok_or_else(|| format!("unterminated entity in {raw:?}"))?;
            let entity = &rest[i + 1..i + end];
            let c = match entity {
                "amp" => '&',
                "lt" => '<',
                "gt" => '>',
                "quot" => '"',
                "apos" => '\'',
                _ => {
                    let code = if let Some(hex) = entity.strip_prefix("#x") {
                        u32::from_str_radix(hex, 16).ok()
                    } else if let Some(dec) = entity.strip_prefix('#') {
                        dec.parse().ok()
                    } else {
                        None
                    };
                    code.and_then(char::from_u32)
                        .ok_or_else(|| format!("bad entity &{entity};"))?
                }
            };
            out.push(c);
            rest = &rest[i + end + 1..];
        }
        if rest.contains('<') {
            return Err(format!("'<' in character data {raw:?}"));
        }
        out.push_str(rest);
        Ok(out)
    }
    let is_name = |n: &str| {
        !n.is_empty()
            && n.chars()
                .next()
                .is_some_and(|c| c.is_alphabetic() || c == '_')
            && n.chars()
                .all(|c| c.is_alphanumeric() || matches!(c, '-' | '_' | ':' | '.'))
    };
    let mut stack: Vec<String> = Vec::new();
    let mut texts = Vec::new();
    let mut current = String::new();
    let mut roots = 0;
    let mut rest = s;
    loop {
        let i = rest.find('<').unwrap_or(rest.len());
        let data = decode(&rest[..i])?;
        if stack.is_empty() && !data.trim().is_empty() {
            return Err(format!("text outside the root element: {data:?}"));
        }
        if stack.last().map(String::as_str) == Some("text") {
            current.push_str(&data);
        }
        rest = &rest[i..];
        if rest.is_empty() {
            break;
        }
        if let Some(r) = rest.strip_prefix("<?") {
            rest = &r[r.find("?>").ok_or("unclosed <?")? + 2..];
            continue;
        }
        if let Some(r) = rest.strip_prefix("<!--") {
            rest = &r[r.find("-->").ok_or("unclosed comment")? + 3..];
            continue;
        }
        let end = rest.find('>').ok_or("unclosed tag")?;
        let tag = &rest[1..end];
        rest = &rest[end + 1..];
        if let Some(name) = tag.strip_prefix('/') {
            let open = stack.pop().ok_or(format!("</{name}> closes nothing"))?;
            if open != name.trim() {
                return Err(format!("<{open}> closed by </{name}>"));
            }
            if open == "text" {
                texts.push(std::mem::take(&mut current).trim().to_string());
            }
            continue;
        }
        let self_closing = tag.ends_with('/');
        let body = tag.strip_suffix('/').unwrap_or(tag);
        let name_end = body.find(char::is_whitespace).unwrap_or(body.len());
        let name = &body[..name_end];
        if !is_name(name) {
            return Err(format!("bad element name {name:?}"));
        }
        // Attributes: name="value" or name='value', each name once.
        let mut attrs = body[name_end..].trim_start();
        let mut seen = Vec::new();
        while !attrs.is_empty() {
            let eq = attrs
                .find('=')
                .ok_or(format!("attribute without value in <{name}>"))?;
            let attr = attrs[..eq].trim();
            if !is_name(attr) || seen.contains(&attr) {
                return Err(format!("bad or repeated attribute {attr:?} in <{name}>"));
            }
            seen.push(attr);
            let after = attrs[eq + 1..].trim_start();
            let quote = after
                .chars()
                .next()
                .filter(|c| matches!(c, '"' | '\''))
                .ok_or(format!("unquoted attribute {attr} in <{name}>"))?;
            let close = after[1..]
                .find(quote)
                .ok_or(format!("unterminated attribute {attr} in <{name}>"))?;
            decode(&after[1..1 + close])?;
            attrs = after[close + 2..].trim_start();
        }
        if stack.is_empty() {
            roots += 1;
            if roots > 1 {
                return Err("more than one root element".into());
            }
        }
        if !self_closing {
            stack.push(name.to_string());
            if name == "text" {
                current.clear();
            }
        }
    }
    if let Some(open) = stack.last() {
        return Err(format!("<{open}> is never closed"));
    }
    if roots != 1 {
        return Err("no root element".into());
    }
    Ok(texts)
}

#[test]
fn the_xml_checker_rejects_what_is_not_xml() {
    assert_eq!(
        xml_texts("<svg a=\"1\"><text>x &amp; y</text></svg>").unwrap(),
        ["x & y"]
    );
    for bad in [
        "<svg><text>x</svg>",
        "<svg a=1></svg>",
        "<svg a=\"1\" a=\"2\"></svg>",
        "<svg></svg><svg></svg>",
        "<svg><text>a & b</text></svg>",
        "<svg>",
        "text<svg></svg>",
    ] {
        assert!(xml_texts(bad).is_err(), "{bad}");
    }
}

/// Ω on the energy ellipsoid of I = diag(1, 2, 3) through Ω_a = (3, 0, 0), ξ ⊥ Ω.
fn table(n: usize, b: f64) -> TrajectoryTable {
    let mut tab = TrajectoryTable::default();
    for i in 0..n {
        let t = b * i as f64 / (n - 1) as f64;
        let (s, c) = (0.5 * t).sin_cos();
        // ⟨Ω, IΩ⟩ = 9: Ω = (3c, 3s/√2, 0).
        let omega = [3.0 * c, 3.0 * s / 2f64.sqrt(), 0.0];
        tab.t.push(t);
        tab.omega.push(omega);
        tab.xi.push([-s, c, 0.3 * s]);
        tab.xi_dot.push([-0.5 * c, -0.5 * s, 0.15 * c]);
        tab.kappa.push([s, c, -s]);
        tab.omega_d.push([3.0 * c, 0.0, 3.0 * s / 3f64.sqrt()]);
    }
    tab
}

fn options(format: FigureFormat) -> FigureOptions {
    let e = EnergyEllipsoid::through([1.0, 2.0, 3.0], [3.0, 0.0, 0.0]).unwrap();
    let mut o = FigureOptions::new("case", e);
    o.format = format;
    o.size = (800, 600);
    o
}

const PAPER_CAPTION: &str = "eta_1: α = 1, β = 0.1, γ = 1, η = 1, δ = 0.2, b = 11.3596";

#[test]
fn the_subtitle_is_the_papers_caption() {
    let weights = [("α", 1.0), ("β", 0.1), ("γ", 1.0), ("η", 1.0), ("δ", 0.2)];
    assert_eq!(
        case_subtitle("eta_1", &weights, 11.359616203476822),
        PAPER_CAPTION
    );
    assert_eq!(
        case_subtitle("x", &[("η", 0.01)], 9.8383264),
        "x: η = 0.01, b = 9.83833"
    );
}

#[test]
fn every_figure_is_well_formed_svg_with_both_title_lines() {
    let tab = table(400, 10.0);
    let mut o = options(FigureFormat::Svg);
    o.subtitle = Some(PAPER_CAPTION.to_string());
    let own_titles = [
        (Figure::Omega3d, "Ω, Ω_d and ξ_∥ on the energy ellipsoid E"),
        (Figure::Constraint, "Constraint ⟨Ω, ξ⟩; max |⟨Ω, ξ⟩| = "),
        (Figure::XiNorm, "Magnitude of the control vector |ξ|"),
        (Figure::Kappa, "Costates κ(t)"),
        (
            Figure::OmegaComponents,
            "Body angular velocity Ω and desired Ω_d",
        ),
        (Figure::Xi, "Control vector ξ(t)"),
        (Figure::XiDot, "Rate of the control vector: u = dξ/dt"),
    ];
    assert_eq!(own_titles.len(), Figure::ALL.len());
    for (fig, title) in own_titles {
        let svg = String::from_utf8(render_figure_bytes(fig, &tab, &o).unwrap()).unwrap();
        let texts = xml_texts(&svg).unwrap_or_else(|e| panic!("{fig:?}: {e}"));
        assert!(texts[0].starts_with(title), "{fig:?}: {texts:?}");
        assert_eq!(texts[1], PAPER_CAPTION, "{fig:?}");
        // The case name is in the subtitle, not repeated after the title.
        assert!(!texts[0].contains("(case)"), "{fig:?}: {}", texts[0]);
        // Wide lines turn with round joins (a miter join spikes at sharp turns).
        let polylines = svg.matches("<polyline").count();
        assert!(polylines > 0, "{fig:?}: no polyline");
        assert_eq!(
            svg.matches("<polyline stroke-linejoin=\"round\" stroke-linecap=\"round\"")
                .count(),
            polylines,
            "{fig:?}"
        );
    }
    // The components of ξ and ξ̇ have their legend entries.
    for (fig, names) in [
        (Figure::Xi, ["ξ₁", "ξ₂", "ξ₃"]),
        (Figure::XiDot, ["dξ₁/dt", "dξ₂/dt", "dξ₃/dt"]),
    ] {
        let svg = String::from_utf8(render_figure_bytes(fig, &tab, &o).unwrap()).unwrap();
        let texts = xml_texts(&svg).unwrap();
        for name in names {
            assert!(
                texts.iter().any(|t| t == name),
                "{fig:?}: no {name} in {texts:?}"
            );
        }
    }
    // Without a subtitle, the case name follows the title on one line.
    o.subtitle = None;
    let svg = render_figure_bytes(Figure::Kappa, &tab, &o).unwrap();
    let texts = xml_texts(&String::from_utf8(svg).unwrap()).unwrap();
    assert_eq!(texts[0], "Costates κ(t) (case)");
}

/// The texts of the 3-D figure's and the Ω figure's SVGs.
fn omega_texts(o: &FigureOptions) -> Vec<String> {
    let tab = table(300, 8.0);
    [Figure::Omega3d, Figure::OmegaComponents]
        .iter()
        .flat_map(|&fig| {
            let svg = render_figure_bytes(fig, &tab, o).unwrap();
            xml_texts(&String::from_utf8(svg).unwrap()).unwrap()
        })
        .collect()
}

#[test]
fn omega_d_not_in_the_cost_is_not_called_desired() {
    let mut o = options(FigureFormat::Svg);
    o.desired_extended = Some(table(300, 9.0).omega_d);
    let with = omega_texts(&o);
    for label in ["Ω_d (desired)", "dashed: Ω_d", "Ω_d(b)"] {
        assert!(with.iter().any(|t| t == label), "no {label:?} in {with:?}");
    }
    o.desired_in_cost = false;
    let without = omega_texts(&o);
    for t in &without {
        assert!(!t.to_lowercase().contains("desired"), "{t:?}");
        assert!(!t.contains("Ω_d"), "{t:?}");
    }
    for label in [
        "reference path",
        "(not in the cost)",
        "reference path at b",
        "dashed: reference path (not in the cost)",
    ] {
        assert!(
            without.iter().any(|t| t == label),
            "no {label:?} in {without:?}"
        );
    }
}

#[test]
fn the_3d_figure_names_its_axes_and_each_marker() {
    let o = options(FigureFormat::Svg);
    let svg = render_figure_bytes(Figure::Omega3d, &table(300, 8.0), &o).unwrap();
    let texts = xml_texts(&String::from_utf8(svg).unwrap()).unwrap();
    for label in [
        "Ω₁",
        "Ω₂",
        "Ω₃",
        "Ω(a), start",
        "Ω(b), end",
        "ξ_∥(a), start",
        "ξ_∥(b), end",
    ] {
        assert_eq!(
            texts.iter().filter(|t| *t == label).count(),
            1,
            "{label:?} in {texts:?}"
        );
    }
}

fn solve(example: &str) -> (PathBuf, Summary) {
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("figures_{example}"));
    let _ = std::fs::remove_dir_all(&out);
    let config = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("examples/{example}.toml"));
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_suslov"))
        .args(["-q", "solve"])
        .arg(&config)
        .arg("--out")
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success(), "{example}");
    let summary =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    (out, summary)
}

/// The subtitle of a case's figures, from its summary (the resolved input's weights and the
/// solution's b).
fn expected_subtitle(summary: &Summary) -> String {
    let c = &summary.cases[0];
    let cost = &c.input.as_ref().expect("input recorded")["cost"];
    let w = |k: &str| cost[k].as_f64().unwrap();
    case_subtitle(
        &c.name,
        &[
            ("α", w("alpha")),
            ("β", w("beta")),
            ("γ", w("gamma")),
            ("η", w("eta")),
            ("δ", w("delta")),
        ],
        c.terminal_time,
    )
}

/// Every figure of a verified case, in both formats: PNG 1200 × 900, SVG well-formed with
/// the subtitle; returns the SVGs' texts by stem.
fn check_case_figures(dir: &Path, subtitle: &str) -> Vec<(&'static str, Vec<String>)> {
    let mut all = Vec::new();
    for fig in Figure::ALL {
        for format in FigureFormat::ALL {
            let path = dir.join(format!("{}.{}", fig.stem(), format.extension()));
            let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            match format {
                FigureFormat::Png => {
                    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{}", path.display());
                    let w = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
                    let h = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
                    assert_eq!((w, h), (1200, 900), "{}", path.display());
                }
                FigureFormat::Svg => {
                    let texts = xml_texts(&String::from_utf8(bytes).unwrap())
                        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                    assert_eq!(texts[1], subtitle, "{}", path.display());
                    all.push((fig.stem(), texts));
                }
            }
        }
    }
    all
}

#[test]
fn solve_writes_every_figure_as_png_and_svg_titled_with_weights_and_b() {
    let (out, summary) = solve("segment");
    assert_eq!(summary.cases[0].status, "converged");
    let subtitle = expected_subtitle(&summary);
    // Measured: b = 3.68771 (tests/config_examples.rs).
    assert!(
        subtitle.starts_with("segment: α = 1, β = 0.1, γ = 1, η = 0.1, δ = 0.1, b = 3.6877"),
        "{subtitle}"
    );
    let texts = check_case_figures(&out, &subtitle);
    let omega_3d = &texts.iter().find(|(s, _)| *s == "omega_3d").unwrap().1;
    assert!(
        omega_3d.iter().any(|t| t == "Ω_d (desired)"),
        "{omega_3d:?}"
    );
}

#[test]
fn without_tracking_no_figure_calls_the_reference_path_desired() {
    let (out, summary) = solve("no_tracking");
    assert_eq!(summary.cases[0].status, "converged");
    let subtitle = expected_subtitle(&summary);
    assert!(subtitle.contains("γ = 0"), "{subtitle}");
    for (stem, texts) in check_case_figures(&out, &subtitle) {
        for t in &texts {
            assert!(!t.to_lowercase().contains("desired"), "{stem}: {t:?}");
        }
    }
    let omega = std::fs::read_to_string(out.join("omega.svg")).unwrap();
    assert!(omega.contains("dashed: reference path (not in the cost)"));
}
