//! Tests of the SVG figures: each writes a figure, parses it as XML and checks what a reader of
//! the figure relies on (labels, legend, dashes, markers, cells), not merely that it was written.
//!
//! The checks lean on how `plotters` 0.3.7 writes SVG (see the `plot` module docs): texts are
//! `<text>` elements holding the string verbatim, a solid curve is one `<polyline>` in the series
//! colour, a dashed curve is one short `<polyline>` per dash (no `stroke-dasharray`).

use crate::svg;

use helixbif::Error;
use helixbif::plot::{
    Figure, Heatmap, Layout, Marker, MarkerShape, PNG_SCALE, Rect, Scale, Series, Style,
    missing_glyphs, png_path, render_figure, render_heatmap, render_panels, write_figure,
    write_heatmap, write_panels,
};
use roxmltree::{Document, Node};
use std::path::PathBuf;
use svg::*;

/// Number of points of a branch, and where each branch loses stability.
const N: usize = 21;
const A_UNSTABLE_FROM: usize = 10;
const B_UNSTABLE_FROM: usize = 14;

fn omega() -> Vec<f64> {
    (0..N).map(|i| i as f64 * 0.5).collect()
}

fn branch_figure() -> Figure {
    let w = omega();
    let stable_until = |k: usize| Some((0..N).map(|i| i < k).collect());
    Figure {
        title: "Whirling branches".into(),
        x_label: "omega (rad/s)".into(),
        y_label: "amplitude (mm)".into(),
        series: vec![
            line(
                "branch A",
                w.clone(),
                w.iter().map(|w| 0.1 * w * w).collect(),
                stable_until(A_UNSTABLE_FROM),
            ),
            Series {
                // Uncertain amplitude: drawn as a shaded band, which does not add polylines.
                err: Some(vec![0.4; N]),
                ..line(
                    "branch B",
                    w.clone(),
                    w.iter().map(|w| 10.0 - 0.5 * w).collect(),
                    stable_until(B_UNSTABLE_FROM),
                )
            },
            Series {
                label: "reference".into(),
                x: vec![0.0, 10.0],
                y: vec![5.0, 5.0],
                style: Style::Dashed,
                stable: None,
                err: None,
            },
        ],
        markers: vec![
            Marker {
                label: "hopf".into(),
                x: 4.75,
                y: 2.26,
            },
            Marker {
                label: "fold".into(),
                x: 6.75,
                y: 6.6,
            },
        ],
        ..Figure::default()
    }
}

/// Checks the runs of one branch drawn in `color` that is stable for its first `k` points.
///
/// How the polylines are counted: the stable run is ONE polyline through points 0..k plus the
/// midpoint to point k (k + 1 vertices); the unstable run is cut into dashes, each its own short
/// polyline; the legend sample is one horizontal two-point polyline longer than a dash. So the
/// colour has exactly two polylines that are not dashes, and the dashes lie right of the solid
/// run (omega increases along the branch) and reach the last point.
fn check_branch(doc: &Document, color: &str, k: usize) {
    let all = polylines(doc, color);
    let (dashes, long): (Vec<&Line>, Vec<&Line>) = all.iter().partition(|l| is_dash(l));
    assert_eq!(
        long.len(),
        2,
        "{color}: one solid run and one legend sample"
    );
    let solid = long
        .iter()
        .find(|l| l.len() > 2)
        .expect("the solid run has many vertices");
    assert_eq!(
        solid.len(),
        k + 1,
        "{color}: stable points plus the midpoint"
    );
    assert!(
        long.iter().any(|l| is_horizontal_pair(l)),
        "{color}: legend sample"
    );

    // omega = 0.5 i maps linearly to pixels; the solid run's first vertex is point 0 and its
    // next-to-last vertex is point k - 1, which fixes the map.
    let (x0, xk) = (solid[0].0, solid[k - 1].0);
    let px_per_point = (xk - x0) / (k - 1) as f64;
    let last_point_px = x0 + px_per_point * (N - 1) as f64;
    let solid_end = solid[k].0;
    assert!(dashes.len() >= 5, "{color}: the unstable run is dashed");
    for dash in &dashes {
        for &(x, _) in dash.iter() {
            assert!(
                x >= solid_end - 1.0 && x <= last_point_px + 1.0,
                "{color}: dash at {x}"
            );
        }
    }
    let reach = dashes
        .iter()
        .flat_map(|d| d.iter().map(|p| p.0))
        .fold(f64::MIN, f64::max);
    let pattern = f64::from(helixbif::plot::DASH_PX + helixbif::plot::GAP_PX);
    assert!(
        reach >= last_point_px - pattern - 1.0,
        "{color}: dashes reach the last point ({reach} vs {last_point_px})"
    );
}

#[test]
fn branch_figure_has_labels_legend_and_dashed_unstable_runs() {
    write_figure(&branch_figure(), &out("branches")).unwrap();
    let svg = read("branches");
    let doc = parse(&svg);

    for label in ["omega (rad/s)", "amplitude (mm)", "Whirling branches"] {
        assert_eq!(count_text(&doc, label), 1, "text {label:?}");
    }
    // Each legend label once, although each branch is drawn as several runs.
    for label in [
        "branch A",
        "branch B",
        "reference",
        "hopf",
        "fold",
        "unstable (dashed)",
    ] {
        assert_eq!(count_text(&doc, label), 1, "legend entry {label:?}");
    }
    assert!(
        !svg.contains("stroke-dasharray"),
        "plotters draws dashes as separate polylines"
    );

    check_branch(&doc, BLUE, A_UNSTABLE_FROM);
    check_branch(&doc, VERMILLION, B_UNSTABLE_FROM);

    // The Dashed reference line (and its legend sample) consists of dashes only.
    let reference = polylines(&doc, GREEN);
    assert!(reference.len() >= 10);
    assert!(reference.iter().all(is_dash));

    // The "unstable (dashed)" sample is a neutral dashed line.
    let neutral = polylines(&doc, NEUTRAL);
    assert!(neutral.len() >= 2 && neutral.iter().all(is_dash));

    // Branch B's error band: one translucent polygon along the whole branch (both edges).
    let bands: Vec<Node> = elements(&doc, "polygon")
        .into_iter()
        .filter(|n| n.attribute("fill") == Some(VERMILLION))
        .collect();
    assert_eq!(bands.len(), 1);
    assert_eq!(bands[0].attribute("opacity"), Some("0.2"));
    let vertices = bands[0]
        .attribute("points")
        .unwrap()
        .split_whitespace()
        .count();
    assert_eq!(vertices, 2 * N);

    // Special points: a black diamond and a black triangle, each also in the legend.
    let black_polygons = elements(&doc, "polygon")
        .iter()
        .filter(|n| n.attribute("fill") == Some("#000000"))
        .count();
    assert_eq!(black_polygons, 4);
}

/// A title wider than the figure (a sweep figure's, which names its error bars and their range)
/// is broken at spaces into lines stacked top down, each its own text at the title size, the
/// words in their order; a short title stays one line.
#[test]
fn a_long_title_is_broken_into_lines_inside_the_frame() {
    let title = "ω_b against λ/ℓ (bars: estimated error, discretization and quadrature, 0.015 to \
                 0.093% of the value; every point refined to a relative accuracy of 1e-3)";
    let fig = Figure {
        title: title.into(),
        ..branch_figure()
    };
    write_figure(&fig, &out("long-title")).unwrap();
    let svg = read("long-title");
    let doc = parse(&svg);
    let lines: Vec<Node> = elements(&doc, "text")
        .into_iter()
        .filter(|n| n.attribute("font-size") == Some("20"))
        .collect();
    assert!(lines.len() >= 2, "{} title lines", lines.len());
    let words: Vec<String> = lines
        .iter()
        .map(|n| n.text().unwrap_or("").trim().to_owned())
        .collect();
    assert_eq!(words.join(" "), title);
    for pair in lines.windows(2) {
        assert!(attr(&pair[1], "y") > attr(&pair[0], "y"));
    }
    // In the PNG, the title band has ink, and none of it reaches the outer 10 px on either side
    // of the frame.
    let (width, height, pixels) = png_pixels(&out("long-title"));
    let channels = pixels.len() / (width * height);
    let top = (attr(lines.last().unwrap(), "y") as usize + 20) * PNG_SCALE as usize;
    let margin = 10 * PNG_SCALE as usize;
    let dark = |row: usize, column: usize| {
        let at = (row * width + column) * channels;
        pixels[at..at + 3].iter().any(|&b| b < 128)
    };
    assert!((0..top).any(|row| (margin..width - margin).any(|column| dark(row, column))));
    for row in 0..top {
        for column in (0..margin).chain(width - margin..width) {
            let at = (row * width + column) * channels;
            assert!(
                pixels[at..at + 3].iter().all(|&b| b > 200),
                "ink at ({column}, {row}) of the title band"
            );
        }
    }
}

/// The PNG beside `svg`: its width, height and pixels.
fn png_pixels(svg: &std::path::Path) -> (usize, usize, Vec<u8>) {
    let file = std::fs::File::open(png_path(svg)).expect("the PNG was written beside the SVG");
    let decoder = png::Decoder::new(std::io::BufReader::new(file));
    let mut reader = decoder.read_info().expect("the PNG decodes");
    let mut buf = vec![0; reader.output_buffer_size().expect("a sane size")];
    let info = reader
        .next_frame(&mut buf)
        .expect("the PNG's pixels decode");
    buf.truncate(info.buffer_size());
    (info.width as usize, info.height as usize, buf)
}

#[test]
fn log_log_markers_with_error_bars_and_annotation() {
    let fig = Figure {
        x_label: "frequency (Hz)".into(),
        y_label: "thrust (nN)".into(),
        x_scale: Scale::Log,
        y_scale: Scale::Log,
        series: vec![Series {
            label: "measured".into(),
            // The last three points cannot be shown on log axes (x <= 0, y = 0, NaN) and are
            // skipped; the fourth one's error bar reaches below zero and is cut at the axis.
            x: vec![1.0, 10.0, 100.0, 1000.0, -1.0, 50.0, 20.0],
            y: vec![2.0, 20.0, 100.0, 800.0, 5.0, 0.0, f64::NAN],
            style: Style::Markers(MarkerShape::Circle),
            stable: None,
            err: Some(vec![0.5, 5.0, 50.0, 900.0, 1.0, 1.0, 1.0]),
        }],
        annotation: Some("m = 0.62 ± 0.03\nfit: 2 < f < 1000".into()),
        ..Figure::default()
    };
    write_figure(&fig, &out("loglog")).unwrap();
    let svg = read("loglog");
    let doc = parse(&svg);

    assert_eq!(count_text(&doc, "m = 0.62 ± 0.03"), 1);
    assert_eq!(count_text(&doc, "fit: 2 < f < 1000"), 1);
    for label in ["frequency (Hz)", "thrust (nN)", "1", "10", "100", "1000"] {
        assert!(count_text(&doc, label) >= 1, "text {label:?}");
    }
    // A single series and no special points: no legend.
    assert_eq!(count_text(&doc, "measured"), 0);

    let mut circles: Vec<(f64, f64)> = elements(&doc, "circle")
        .iter()
        .filter(|n| n.attribute("fill") == Some(BLUE))
        .map(|n| (attr(n, "cx"), attr(n, "cy")))
        .collect();
    assert_eq!(circles.len(), 4, "one marker per drawable point");
    circles.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Decades are equally spaced on a log axis.
    let gaps: Vec<f64> = circles.windows(2).map(|w| w[1].0 - w[0].0).collect();
    assert!(gaps.iter().all(|g| (g - gaps[0]).abs() <= 1.0), "{gaps:?}");

    let lines = polylines(&doc, BLUE);
    let bars: Vec<&Line> = lines.iter().filter(|l| is_vertical_pair(l)).collect();
    let caps: Vec<&Line> = lines.iter().filter(|l| is_horizontal_pair(l)).collect();
    assert_eq!(bars.len(), 4);
    // Two caps per bar, except at the lower end of 800 ± 900, which is cut at the axis.
    assert_eq!(caps.len(), 7);
    let (cut_x, _) = circles[3];
    let cut_bar = bars
        .iter()
        .find(|b| b[0].0 == cut_x)
        .expect("bar of 800 ± 900");
    let cut_bottom = cut_bar[0].1.max(cut_bar[1].1);
    assert!(
        !caps
            .iter()
            .any(|c| c[0].1 == cut_bottom && (c[0].0 - cut_x).abs() < 10.0)
    );

    // 100 ± 50 on a log axis: the bar reaches ln(1.5)/ln(2) as far up as down.
    let (cx, cy) = circles[2];
    let bar = bars
        .iter()
        .find(|b| b[0].0 == cx)
        .expect("bar through the marker");
    let (top, bottom) = (bar[0].1.min(bar[1].1), bar[0].1.max(bar[1].1));
    let ratio = (cy - top) / (bottom - cy);
    assert!(
        (ratio - 1.5f64.ln() / 2f64.ln()).abs() < 0.05,
        "ratio {ratio}"
    );
}

fn phase_diagram(nan_cells: &[(usize, usize)]) -> Heatmap {
    let x: Vec<f64> = (0..10).map(f64::from).collect();
    let y: Vec<f64> = (0..6).map(|i| f64::from(i) * 0.2).collect();
    let mut z: Vec<Vec<f64>> = y
        .iter()
        .map(|yi| x.iter().map(|xj| xj * yi).collect())
        .collect();
    for &(i, j) in nan_cells {
        z[i][j] = f64::NAN;
    }
    Heatmap {
        title: "Stability map".into(),
        x_label: "omega (rad/s)".into(),
        y_label: "stiffness ratio".into(),
        colorbar_label: "growth rate (1/s)".into(),
        x: x.clone(),
        y,
        z,
        overlays: vec![
            line(
                "boundary",
                x.clone(),
                x.iter().map(|xi| 1.0 - 0.08 * xi).collect(),
                None,
            ),
            Series {
                label: "observed".into(),
                x: vec![3.0, 6.0],
                y: vec![0.5, 0.3],
                style: Style::Markers(MarkerShape::Square),
                stable: None,
                err: Some(vec![0.1, 0.05]),
            },
        ],
        smooth_y: false,
    }
}

/// `<rect>`s filled with an opaque colour other than the white background.
fn filled_rects(doc: &Document) -> Vec<String> {
    elements(doc, "rect")
        .iter()
        .filter(|n| n.attribute("opacity") == Some("1"))
        .filter_map(|n| n.attribute("fill"))
        .filter(|fill| *fill != "none" && *fill != "#FFFFFF")
        .map(str::to_owned)
        .collect()
}

#[test]
fn heatmap_has_cells_colorbar_and_overlays() {
    let nan = [(2, 3), (5, 9)];
    write_heatmap(&phase_diagram(&nan), &out("heatmap-nan")).unwrap();
    write_heatmap(&phase_diagram(&[]), &out("heatmap")).unwrap();
    let (with_nan, full) = (read("heatmap-nan"), read("heatmap"));
    let (with_nan, full) = (parse(&with_nan), parse(&full));

    for label in [
        "growth rate (1/s)",
        "omega (rad/s)",
        "stiffness ratio",
        "Stability map",
        "boundary",
        "observed",
    ] {
        assert_eq!(count_text(&with_nan, label), 1, "text {label:?}");
    }
    let cells = 10 * 6;
    let (filled_nan, filled_full) = (filled_rects(&with_nan), filled_rects(&full));
    assert!(filled_nan.len() >= cells - nan.len());
    assert!(filled_full.len() >= cells);
    // NaN cells are left blank and nothing else changes.
    assert_eq!(filled_full.len() - filled_nan.len(), nan.len());
    // The smallest and largest values get the two ends of viridis.
    assert!(filled_full.iter().any(|f| f == "#440154"));
    assert!(filled_full.iter().any(|f| f == "#FDE725"));

    // The boundary overlay is one solid polyline through its ten points (the first overlay
    // colour is vermillion, absent from viridis).
    let boundary = polylines(&with_nan, VERMILLION);
    assert!(boundary.iter().any(|l| l.len() == 10));
}

fn view(title: &str, x_label: &str, y_label: &str) -> Figure {
    let s: Vec<f64> = (0..50).map(|i| f64::from(i) / 49.0).collect();
    Figure {
        title: title.into(),
        x_label: x_label.into(),
        y_label: y_label.into(),
        series: vec![line(
            "centreline",
            s.iter().map(|s| (6.0 * s).cos() * 0.2).collect(),
            s.clone(),
            None,
        )],
        ..Figure::default()
    }
}

#[test]
fn panels_sit_side_by_side_with_their_own_axes() {
    let panels = [
        view("front view", "x (mm)", "z (mm)"),
        view("side view", "y (mm)", "z (mm) side"),
    ];
    write_panels(&panels, &out("panels"), (1200, 500)).unwrap();
    let svg = read("panels");
    let doc = parse(&svg);
    assert_eq!(doc.root_element().attribute("width"), Some("1200"));

    let x_of = |label: &str| {
        let node = elements(&doc, "text")
            .into_iter()
            .find(|n| n.text().map(str::trim) == Some(label))
            .unwrap_or_else(|| panic!("text {label:?}"));
        attr(&node, "x")
    };
    for label in ["front view", "x (mm)", "z (mm)"] {
        assert!(x_of(label) < 600.0, "{label:?} is in the left panel");
    }
    for label in ["side view", "y (mm)", "z (mm) side"] {
        assert!(x_of(label) > 600.0, "{label:?} is in the right panel");
    }
    // Each panel draws its own curve.
    assert_eq!(polylines(&doc, BLUE).len(), 2);
}

#[test]
fn degenerate_data_give_valid_figures() {
    let nan = f64::NAN;
    let series = |x: Vec<f64>, y: Vec<f64>| line("s", x, y, None);
    let figures = [
        ("nothing", Figure::default()),
        (
            "empty",
            Figure {
                series: vec![series(vec![], vec![]), series(vec![], vec![])],
                markers: vec![Marker {
                    label: "fold".into(),
                    x: nan,
                    y: 1.0,
                }],
                annotation: Some(String::new()),
                ..Figure::default()
            },
        ),
        (
            "all-nan",
            Figure {
                series: vec![series(vec![nan, nan], vec![nan, f64::INFINITY])],
                ..Figure::default()
            },
        ),
        (
            "constant",
            Figure {
                series: vec![series(vec![1.0; 5], vec![3.0; 5])],
                ..Figure::default()
            },
        ),
        (
            "log-non-positive",
            Figure {
                x_scale: Scale::Log,
                y_scale: Scale::Log,
                series: vec![series(vec![0.0, -1.0], vec![1.0, 2.0])],
                ..Figure::default()
            },
        ),
        (
            "extreme",
            Figure {
                series: vec![
                    series(vec![-f64::MAX, f64::MAX], vec![f64::MAX, -f64::MAX]),
                    Series {
                        style: Style::Markers(MarkerShape::Cross),
                        stable: Some(vec![false]),
                        err: Some(vec![f64::INFINITY]),
                        ..series(vec![0.0], vec![f64::MIN_POSITIVE])
                    },
                ],
                ..Figure::default()
            },
        ),
    ];
    for (name, fig) in &figures {
        write_figure(fig, &out(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        parse(&read(name));
    }

    // Constant values: the axis is widened around the value, which gets a tick label.
    let constant = read("constant");
    let doc = parse(&constant);
    let ticks: Vec<f64> = texts(&doc).iter().filter_map(|t| t.parse().ok()).collect();
    assert!(ticks.iter().any(|&t| t < 3.0) && ticks.iter().any(|&t| t > 3.0));
    assert!(ticks.contains(&3.0));

    // A lone point of a line series is still drawn, as a dot.
    let single = Figure {
        series: vec![series(vec![2.0, nan], vec![1.0, 4.0])],
        ..Figure::default()
    };
    write_figure(&single, &out("single")).unwrap();
    let single = read("single");
    let doc = parse(&single);
    let dots = elements(&doc, "circle")
        .iter()
        .filter(|n| n.attribute("fill") == Some(BLUE))
        .count();
    assert_eq!(dots, 1);

    let maps = [
        ("map-empty", Heatmap::default()),
        (
            "map-all-nan",
            Heatmap {
                x: vec![0.0, 1.0],
                y: vec![0.0],
                z: vec![vec![nan, nan]],
                ..Heatmap::default()
            },
        ),
        (
            "map-single",
            Heatmap {
                x: vec![5.0],
                y: vec![0.0],
                z: vec![vec![2.0]],
                overlays: vec![series(vec![], vec![])],
                ..Heatmap::default()
            },
        ),
        (
            "map-constant",
            Heatmap {
                x: vec![0.0, 1.0, 2.0],
                y: vec![2.0, 1.0],
                z: vec![vec![7.0; 3]; 2],
                ..Heatmap::default()
            },
        ),
    ];
    for (name, map) in &maps {
        write_heatmap(map, &out(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        parse(&read(name));
    }

    write_panels(
        &[figures[1].1.clone(), figures[2].1.clone()],
        &out("panels-degenerate"),
        (800, 300),
    )
    .unwrap();
    parse(&read("panels-degenerate"));
}

#[test]
fn malformed_input_is_an_input_error_and_bad_paths_an_io_error() {
    let short = Figure {
        series: vec![line("s", vec![1.0, 2.0], vec![1.0], None)],
        ..Figure::default()
    };
    assert!(write_figure(&short, &out("short")).unwrap_err().is_input());
    let mask = Figure {
        series: vec![line("s", vec![1.0, 2.0], vec![1.0, 2.0], Some(vec![true]))],
        ..Figure::default()
    };
    assert!(write_figure(&mask, &out("mask")).unwrap_err().is_input());

    let ragged = Heatmap {
        x: vec![0.0, 1.0],
        y: vec![0.0, 1.0],
        z: vec![vec![1.0, 2.0], vec![3.0]],
        ..Heatmap::default()
    };
    assert!(
        write_heatmap(&ragged, &out("ragged"))
            .unwrap_err()
            .is_input()
    );
    let unsorted = Heatmap {
        x: vec![0.0, 2.0, 1.0],
        y: vec![0.0],
        z: vec![vec![1.0; 3]],
        ..Heatmap::default()
    };
    assert!(
        write_heatmap(&unsorted, &out("unsorted"))
            .unwrap_err()
            .is_input()
    );

    assert!(
        write_panels(&[], &out("none"), (800, 600))
            .unwrap_err()
            .is_input()
    );
    let two = [Figure::default(), Figure::default()];
    assert!(
        write_panels(&two, &out("tiny"), (300, 600))
            .unwrap_err()
            .is_input()
    );

    let missing = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("no-such-dir/figure.svg");
    match write_figure(&Figure::default(), &missing) {
        Err(Error::Io { path, .. }) => assert!(path.ends_with("figure.svg")),
        other => panic!("expected an I/O error, got {other:?}"),
    }
}

/// Data in every corner of the plot area and none at the middle of its left side (a branch
/// across the top and a collapsed branch along the bottom): the legend goes to the middle of
/// the left side, where it hides nothing.
#[test]
fn a_legend_that_would_hide_data_in_every_corner_goes_to_the_middle_of_a_side() {
    let line = |label: &str, y: f64| Series {
        label: label.into(),
        x: (0..=40).map(|i| i as f64 / 40.0).collect(),
        y: vec![y; 41],
        style: Style::Line,
        stable: None,
        err: None,
    };
    write_figure(
        &Figure {
            title: "corners taken".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            series: vec![line("top", 1.0), line("bottom", 0.0)],
            ..Figure::default()
        },
        &out("legend-middle"),
    )
    .unwrap();
    let svg = read("legend-middle");
    let doc = parse(&svg);
    let position = |label: &str| {
        let n = elements(&doc, "text")
            .into_iter()
            .find(|n| n.text().unwrap_or("").trim() == label)
            .unwrap_or_else(|| panic!("text {label:?}"));
        (attr(&n, "x"), attr(&n, "y"))
    };
    // The data lines' heights in pixels: their polylines in the first two series colours.
    let height = |color: &str| {
        polylines(&doc, color)
            .into_iter()
            .max_by_key(|l| l.len())
            .map(|l| l[0].1)
            .unwrap()
    };
    let (top, bottom) = (height(BLUE), height(VERMILLION));
    let (x_top, y_top) = position("top");
    let (_, y_bottom) = position("bottom");
    let third = (bottom - top) / 3.0;
    assert!(
        y_top > top + third && y_bottom < bottom - third,
        "legend rows at {y_top}, {y_bottom}; data at {top} and {bottom}"
    );
    let (x_label, _) = position("x");
    assert!(
        x_top < x_label,
        "legend at x = {x_top}, the middle at {x_label}"
    );
}

// ---- What a reader of a paper relies on: legends and annotations over no data, the formulas
// ---- in Unicode, equal scales for shapes, and a PNG beside every SVG.

/// Checks that the legend and the annotation of `layout` cover none of the data's boxes nor
/// each other, and lie inside the image of `size`.
fn check_boxes_clear(layout: &Layout, size: (i32, i32), what: &str) {
    let image = Rect::sized((0, 0), size);
    for (name, boxed) in [("legend", layout.legend), ("annotation", layout.annotation)] {
        let Some(b) = boxed else { continue };
        assert!(image.contains(&b), "{what}: {name} {b:?} outside the image");
        if let Some(d) = layout.data.iter().find(|d| d.intersects(&b)) {
            panic!("{what}: {name} {b:?} covers data at {d:?}");
        }
    }
    if let (Some(l), Some(a)) = (layout.legend, layout.annotation) {
        assert!(
            !l.intersects(&a),
            "{what}: legend {l:?} over the annotation {a:?}"
        );
    }
}

/// Decodes the PNG beside `svg` and returns its size.
fn png_size(svg: &std::path::Path) -> (u32, u32) {
    let (width, height, pixels) = png_pixels(svg);
    assert!(
        pixels.iter().any(|&b| b < 128),
        "{}: the PNG has dark pixels (axes, text)",
        svg.display()
    );
    (width as u32, height as u32)
}

/// Markers like the collapse figure's, a dashed power law through them and the fit's
/// annotation: the first point sits in the upper left, where the annotation would go first.
fn collapse_like() -> Figure {
    let x: Vec<f64> = vec![0.2, 0.25, 0.32, 0.4];
    let law = |x: f64| 0.7 * x.powf(-3.19);
    let markers = |label: &str, shape, f: f64| Series {
        label: label.into(),
        x: x.clone(),
        y: x.iter().map(|x| law(*x) * f).collect(),
        style: Style::Markers(shape),
        stable: None,
        err: None,
    };
    let fx: Vec<f64> = (0..=60)
        .map(|i| 0.2 * 2f64.powf(f64::from(i) / 60.0))
        .collect();
    Figure {
        title: "Collapse of ω̄_b on one power law of R/λ".into(),
        x_label: "R/λ (–)".into(),
        y_label: "ω̄_b / C(λ/ℓ) (–)".into(),
        x_scale: Scale::Log,
        y_scale: Scale::Log,
        series: vec![
            markers("λ/ℓ = 0.125", MarkerShape::Circle, 1.0),
            markers("λ/ℓ = 0.1875", MarkerShape::Square, 1.04),
            markers("λ/ℓ = 0.25", MarkerShape::Triangle, 0.97),
            Series {
                label: "(R/λ)⁻ᵐ, m = 3.186".into(),
                x: fx.clone(),
                y: fx.iter().map(|x| law(*x)).collect(),
                style: Style::Dashed,
                stable: None,
                err: None,
            },
        ],
        annotation: Some("m = 3.186, 95 % CI [2.945, 3.426]".into()),
        ..Figure::default()
    }
}

/// A rod hanging along z, 22 units long and 3 wide: the proportions of the shapes study.
fn rod_view(title: &str, horizontal: &str) -> Figure {
    let s: Vec<f64> = (0..=120).map(|i| f64::from(i) / 120.0).collect();
    let helix = |label: &str, r: f64, phase: f64| Series {
        label: label.into(),
        x: s.iter()
            .map(|s| r * (2.0 * std::f64::consts::PI * 7.0 * s + phase).cos())
            .collect(),
        y: s.iter().map(|s| -22.0 * s).collect(),
        style: Style::Line,
        stable: None,
        err: None,
    };
    Figure {
        title: title.into(),
        x_label: format!("{horizontal} (cm)"),
        y_label: "z (cm)".into(),
        series: vec![
            helix("ω = 0 rad/s", 1.5, 0.0),
            helix("ω = 0.2 rad/s", 1.3, 0.5),
            helix("ω = 0.4 rad/s", 1.1, 1.0),
        ],
        equal_scale: true,
        ..Figure::default()
    }
}

#[test]
fn side_by_side_panels_whose_titles_wrap_differently_keep_one_plot_height() {
    let long = "the representative helix seen along x at omega = 0.4 rad/s, N = 237 nodes, \
                RPY line, every shape drawn to one scale";
    let panels = [rod_view(long, "x"), rod_view("seen along y", "y")];
    let drawing = render_panels(&panels, (1000, 800)).unwrap();
    let doc = parse(&drawing.svg);
    let lines = elements(&doc, "text")
        .into_iter()
        .filter(|n| n.attribute("font-size") == Some("20"))
        .count();
    // The first title takes at least two lines, the second one.
    assert!(lines >= 3, "{lines} title lines");
    let [a, b] = [&drawing.layouts[0].plot_area, &drawing.layouts[1].plot_area];
    assert_eq!((a.y0, a.y1), (b.y0, b.y1), "{a:?} against {b:?}");
    // Beside a one-line title, the plot starts higher.
    let short = [rod_view("seen along x", "x"), rod_view("seen along y", "y")];
    let level = render_panels(&short, (1000, 800)).unwrap();
    assert!(level.layouts[1].plot_area.y0 < b.y0);
}

#[test]
fn legends_and_annotations_cover_no_data_in_any_figure_kind() {
    let drawings = [
        (
            "branch",
            render_figure(&branch_figure()).unwrap(),
            (800, 600),
        ),
        (
            "collapse",
            render_figure(&collapse_like()).unwrap(),
            (800, 600),
        ),
        (
            "heatmap",
            render_heatmap(&phase_diagram(&[])).unwrap(),
            (800, 600),
        ),
        (
            "side views",
            render_panels(&[rod_view("a", "x"), rod_view("b", "y")], (1000, 800)).unwrap(),
            (1000, 800),
        ),
    ];
    for (what, drawing, size) in &drawings {
        for layout in &drawing.layouts {
            assert!(!layout.data.is_empty(), "{what}: data boxes recorded");
            assert!(layout.legend.is_some(), "{what}: a legend");
            check_boxes_clear(layout, *size, what);
        }
    }
    // The fit's annotation avoids the first point, in the upper left.
    let collapse = &drawings[1].1.layouts[0];
    assert!(collapse.annotation.is_some());
    // The heat map fills its plot area, so its legend goes below it.
    let map = &drawings[2].1.layouts[0];
    assert!(map.legend_below);
    let legend = map.legend.unwrap();
    assert!(
        legend.y0 > map.plot_area.y1,
        "{legend:?} below {:?}",
        map.plot_area
    );
}

#[test]
fn a_plot_full_of_data_puts_its_legend_and_annotation_below() {
    // A dense cloud of markers over the whole plot area.
    let grid: Vec<(f64, f64)> = (0..40)
        .flat_map(|i| (0..30).map(move |j| (f64::from(i), f64::from(j))))
        .collect();
    let cloud = |label: &str, shift: f64| Series {
        label: label.into(),
        x: grid.iter().map(|p| p.0 + shift).collect(),
        y: grid.iter().map(|p| p.1 + shift).collect(),
        style: Style::Markers(MarkerShape::Circle),
        stable: None,
        err: None,
    };
    let fig = Figure {
        title: "Crowded".into(),
        x_label: "x (m)".into(),
        y_label: "y (m)".into(),
        series: vec![cloud("first", 0.0), cloud("second", 0.5)],
        annotation: Some("fit: none".into()),
        ..Figure::default()
    };
    let drawing = render_figure(&fig).unwrap();
    let layout = &drawing.layouts[0];
    assert!(layout.legend_below && layout.annotation_below, "{layout:?}");
    check_boxes_clear(layout, (800, 600), "crowded");
    for b in [layout.legend.unwrap(), layout.annotation.unwrap()] {
        assert!(b.y0 > layout.plot_area.y1, "{b:?} below the plot");
    }
    // Both are still in the SVG, the legend with its markers.
    let doc = parse(&drawing.svg);
    for label in ["first", "second", "fit: none"] {
        assert_eq!(count_text(&doc, label), 1, "text {label:?}");
    }
}

#[test]
fn side_views_have_equal_scales() {
    let drawing = render_panels(&[rod_view("a", "x"), rod_view("b", "y")], (1000, 800)).unwrap();
    // Two views of one rod with one legend, on the second: both plot areas have one height and
    // one scale, whether or not the legend went below its plot.
    let one_legend = [
        Figure {
            hide_legend: true,
            ..rod_view("a", "x")
        },
        rod_view("b", "y"),
    ];
    let shared = render_panels(&one_legend, (1000, 800)).unwrap();
    let [first, second] = &shared.layouts[..] else {
        panic!("two panels");
    };
    assert!(first.legend.is_none() && second.legend.is_some());
    assert_eq!(first.plot_area.height(), second.plot_area.height());
    assert!((first.px_per_unit.1 / second.px_per_unit.1 - 1.0).abs() < 0.01);
    check_boxes_clear(second, (1000, 800), "second view");
    for layout in drawing.layouts.iter().chain(&shared.layouts) {
        let (sx, sy) = layout.px_per_unit;
        assert!(
            (sx / sy - 1.0).abs() < 0.01,
            "{sx} px per cm along x, {sy} along z"
        );
        // The rod, 22 cm long, fills most of the height.
        assert!(sy * 22.0 > 0.8 * f64::from(layout.plot_area.height()));
    }
    // Without equal scales the x axis would stretch 3 cm over the panel's width.
    let stretched = Figure {
        equal_scale: false,
        ..rod_view("c", "x")
    };
    let (sx, sy) = render_figure(&stretched).unwrap().layouts[0].px_per_unit;
    assert!(sx > 3.0 * sy);
}

#[test]
fn unicode_math_is_written_verbatim_and_the_font_has_every_glyph() {
    let labels = [
        "ω (rad/s)",
        "F̄ₚ = Fₚℓ²/EI (–)",
        "η = Fₚℓ/Tₚ (–)",
        "h̄ = h/h₀ (–)",
        "ω̄_b = ω_b μℓ⁴/EI (–)",
        "m_loc = −d ln ω̄_b / d ln (R/λ) (–)",
        "log₁₀(ω̄ (R/λ)ᵐ) (–)",
        "(R/λ)⁻ᵐ, m = 3.186",
        "λ/ℓ = 0.125",
        "simulation: time average ± std",
        "E r₀⁴/(μ ℓ⁴) (1/s)",
    ];
    for label in labels {
        assert!(
            missing_glyphs(label).is_empty(),
            "{label:?}: {:?}",
            missing_glyphs(label)
        );
    }
    let fig = Figure {
        title: labels[6].into(),
        x_label: labels[0].into(),
        y_label: labels[1].into(),
        series: vec![
            line(labels[2], vec![0.0, 1.0], vec![0.0, 1.0], None),
            line(labels[3], vec![0.0, 1.0], vec![1.0, 0.0], None),
        ],
        annotation: Some(labels[4].into()),
        ..Figure::default()
    };
    let path = out("unicode");
    write_figure(&fig, &path).unwrap();
    let svg = read("unicode");
    let doc = parse(&svg);
    for label in &labels[..5] {
        assert_eq!(count_text(&doc, label), 1, "text {label:?}");
    }
    assert_eq!(png_size(&path), (800 * PNG_SCALE, 600 * PNG_SCALE));
}

#[test]
fn every_figure_kind_is_written_as_svg_and_png() {
    let figure = out("png-figure");
    write_figure(&collapse_like(), &figure).unwrap();
    assert_eq!(png_size(&figure), (800 * PNG_SCALE, 600 * PNG_SCALE));
    let map = out("png-heatmap");
    write_heatmap(&phase_diagram(&[(1, 1)]), &map).unwrap();
    assert_eq!(png_size(&map), (800 * PNG_SCALE, 600 * PNG_SCALE));
    let panels = out("png-panels");
    write_panels(
        &[rod_view("a", "x"), rod_view("b", "y")],
        &panels,
        (1000, 800),
    )
    .unwrap();
    assert_eq!(png_size(&panels), (1000 * PNG_SCALE, 800 * PNG_SCALE));
}

#[test]
fn what_lies_beyond_the_axes_is_cut_at_the_frame() {
    // A heat map whose overlay range reaches far above and below the map, and a figure whose y
    // range leaves out a spike: nothing is drawn outside the plot area.
    let mut map = phase_diagram(&[]);
    map.overlays
        .push(line("range", vec![4.0, 4.0], vec![-3.0, 5.0], None));
    let drawing = render_heatmap(&map).unwrap();
    let layout = &drawing.layouts[0];
    let area = layout.plot_area.inflate(2);
    let doc = parse(&drawing.svg);
    let range_color = "#CC79A7"; // the third overlay colour
    let lines = polylines(&doc, range_color);
    assert!(!lines.is_empty());
    for l in lines.iter().filter(|l| l.len() == 2 && l[0].0 == l[1].0) {
        for &(x, y) in l {
            let p = Rect::spanning((x as i32, y as i32), (x as i32, y as i32));
            assert!(area.contains(&p), "{l:?} leaves the plot area {area:?}");
        }
    }
    // The map itself fills the plot area from frame to frame.
    let covered = |x: i32, y: i32| {
        layout
            .data
            .iter()
            .any(|d| d.contains(&Rect::spanning((x, y), (x, y))))
    };
    let a = layout.plot_area;
    for (x, y) in [(a.x0, a.y0), (a.x1, a.y0), (a.x0, a.y1), (a.x1, a.y1)] {
        assert!(covered(x, y), "corner ({x}, {y}) of the map");
    }

    let mut y: Vec<f64> = (0..20).map(|i| 3.0 + 0.05 * f64::from(i)).collect();
    y[18] = -190.0;
    let spiky = Figure {
        x_label: "R/λ (–)".into(),
        y_label: "m_loc (–)".into(),
        series: vec![line("m_loc", (0..20).map(f64::from).collect(), y, None)],
        y_range: Some((2.5, 4.5)),
        ..Figure::default()
    };
    let drawing = render_figure(&spiky).unwrap();
    let layout = &drawing.layouts[0];
    let doc = parse(&drawing.svg);
    let area = layout.plot_area.inflate(2);
    for l in polylines(&doc, BLUE) {
        for (x, y) in l {
            let p = Rect::spanning((x as i32, y as i32), (x as i32, y as i32));
            assert!(area.contains(&p), "({x}, {y}) outside {area:?}");
        }
    }
    assert!(texts(&doc).iter().any(|t| t == "3.0"), "{:?}", texts(&doc));
}

#[test]
fn a_map_smoothed_along_y_shades_between_row_centres_and_keeps_columns_apart() {
    // Two columns, three rows; z grows with the row in one column and falls in the other.
    let map = |smooth_y: bool| Heatmap {
        x_label: "λ/ℓ (–)".into(),
        y_label: "y (–)".into(),
        x: vec![0.0, 1.0],
        y: vec![0.0, 1.0, 2.0],
        z: vec![vec![0.0, 10.0], vec![5.0, 5.0], vec![10.0, 0.0]],
        smooth_y,
        ..Heatmap::default()
    };
    // The distinct colours of the map's cells (rects left of the colour bar).
    let colours = |drawing: &helixbif::plot::Drawing| {
        let right = f64::from(drawing.layouts[0].plot_area.x1);
        let doc = parse(&drawing.svg);
        let mut c: Vec<String> = elements(&doc, "rect")
            .iter()
            .filter(|n| n.attribute("opacity") == Some("1") && attr(n, "x") < right)
            .filter_map(|n| n.attribute("fill"))
            .filter(|fill| *fill != "none" && *fill != "#FFFFFF")
            .map(str::to_owned)
            .collect();
        c.sort();
        c.dedup();
        c.len()
    };
    let (blocky, smooth) = (
        render_heatmap(&map(false)).unwrap(),
        render_heatmap(&map(true)).unwrap(),
    );
    assert_eq!(colours(&blocky), 3, "the three values");
    assert!(
        colours(&smooth) > 50,
        "{} colours when smoothed",
        colours(&smooth)
    );
    // The map still fills its plot area, and nothing else moved.
    assert_eq!(smooth.layouts[0].plot_area, blocky.layouts[0].plot_area);
    assert_eq!(smooth.layouts[0].data, blocky.layouts[0].data);
}
