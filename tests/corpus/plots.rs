//! `nextpose replay --plots DIR` and the plots library on a small subset of the shared corpus:
//! every figure is written as a PNG that decodes to the documented size and as an SVG document.

use std::path::{Path, PathBuf};

use clap::Parser;
use nextpose::cli::{Cli, run_cli};
use nextpose::engine::EngineConfig;
use nextpose::replay::load_paths;
use nextpose::replay::plots::{
    Figure, PlotGrid, learning_curve, plot_data, render_svg, write_plots,
};

use crate::corpus;

/// Two 60-waypoint RAPID programs of one cell (similar templates: the engine offers guesses).
fn subset() -> Vec<PathBuf> {
    let dir = corpus::json();
    [
        "zwj12__AddInPackages__ZhongXun__Source__RAPID__TASK1__PROGMOD__Template_10014_Module.mod.json",
        "zwj12__AddInPackages__ZhongXun__Source__RAPID__TASK1__PROGMOD__Template_10023_Module.mod.json",
    ]
    .iter()
    .map(|f| dir.join(f))
    .collect()
}

/// A valid PNG of the figure's size: signature, header and every chunk (CRCs, zlib stream) decode.
fn assert_png(path: &Path, size: (u32, u32)) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{}", path.display());
    let decoder = png::Decoder::new(std::io::Cursor::new(&bytes));
    let mut reader = decoder.read_info().unwrap();
    let mut pixels = vec![0; reader.output_buffer_size()];
    let frame = reader.next_frame(&mut pixels).unwrap();
    assert_eq!((frame.width, frame.height), size, "{}", path.display());
    // Not a blank canvas: some pixels are neither white nor one flat colour.
    let distinct: std::collections::BTreeSet<&[u8]> =
        pixels[..frame.buffer_size()].chunks(3).collect();
    assert!(
        distinct.len() > 10,
        "{}: {} colours",
        path.display(),
        distinct.len()
    );
}

fn assert_svg(path: &Path) {
    let text = std::fs::read_to_string(path).unwrap();
    assert!(text.starts_with("<svg"), "{}", path.display());
    assert!(text.trim_end().ends_with("</svg>"), "{}", path.display());
    assert!(text.contains("<text"), "{}: no text", path.display());
}

#[test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
fn library_writes_every_figure_as_png_and_svg() {
    let programs = load_paths(&subset()).unwrap();
    let config = EngineConfig::default();
    let grid = PlotGrid {
        phi_mins: vec![0.0, 0.5, 0.9],
        deltas: vec![0.5, 0.9],
    };
    let data = plot_data(&programs, "default", &config, &grid).unwrap();
    assert_eq!(data.phi_sweep.len(), 3);
    assert_eq!(data.delta_sweep.len(), 2);
    // The learning curve has points: the model learns as the programs are taught.
    let bins = learning_curve(&data.records);
    assert!(bins.iter().any(|b| b.offered > 0), "{bins:?}");

    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plots");
    let written = write_plots(&out, &data).unwrap();
    assert_eq!(written.len(), 2 * Figure::ALL.len() + 1);
    let numbers: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("plots.json")).unwrap()).unwrap();
    assert_eq!(numbers["phi_sweep"].as_array().map(Vec::len), Some(3));
    assert_eq!(
        numbers["learning_curve"].as_array().map(Vec::len),
        Some(bins.len())
    );
    for figure in Figure::ALL {
        assert_png(
            &out.join(format!("{}.png", figure.file_stem())),
            figure.size(),
        );
        assert_svg(&out.join(format!("{}.svg", figure.file_stem())));
    }
    // The captions say what is plotted.
    let svg = render_svg(Figure::PhiMin, &data).unwrap();
    assert!(svg.contains("φ_min"), "{svg}");
    // The reliability of p_useful and the risk–coverage curve, and their numbers.
    let calibration = &numbers["calibration"];
    let bins = calibration["bins"].as_array().expect("reliability bins");
    assert_eq!(bins.len(), 10);
    let counted: u64 = bins.iter().map(|b| b["candidates"].as_u64().unwrap()).sum();
    assert_eq!(Some(counted), calibration["candidates"].as_u64());
    assert!(counted > 0, "the engine had candidates with p_useful");
    assert_eq!(
        calibration["risk_coverage"].as_array().map(Vec::len),
        Some(101)
    );
    let svg = render_svg(Figure::Reliability, &data).unwrap();
    assert!(svg.contains("Reliability of p_useful"), "{svg}");
    let svg = render_svg(Figure::RiskCoverage, &data).unwrap();
    assert!(svg.contains("Risk–coverage"), "{svg}");
}

/// Without an offer rule (the seed) no candidate has a p_useful: the two figures say so, and
/// plots.json has no calibration.
#[test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
fn calibration_figures_without_p_useful_say_so() {
    let programs = load_paths(&subset()[..1]).unwrap();
    let config = EngineConfig::profile(nextpose::engine::Profile::Dissertation);
    let grid = PlotGrid {
        phi_mins: vec![0.5],
        deltas: vec![0.5],
    };
    let data = plot_data(&programs, "seed", &config, &grid).unwrap();
    for figure in [Figure::Reliability, Figure::RiskCoverage] {
        let svg = render_svg(figure, &data).unwrap();
        assert!(svg.contains("no candidate has a p_useful"), "{svg}");
    }
    let numbers: serde_json::Value =
        serde_json::from_str(&nextpose::replay::plots::plotted_json(&data).unwrap()).unwrap();
    assert!(numbers["calibration"].is_null());
}

#[test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
fn replay_cli_writes_plots_into_the_directory() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("nested").join("plots");
    let mut args: Vec<String> = vec!["nextpose".into(), "replay".into(), "--quiet".into()];
    args.extend(subset().iter().map(|p| p.display().to_string()));
    args.extend(["--plots".into(), out.display().to_string()]);
    // Placements kept in the test's directory, not the user's cache.
    let cache = dir.path().join("placements");
    args.extend(["--placement-cache".into(), cache.display().to_string()]);
    run_cli(Cli::try_parse_from(args).unwrap()).unwrap();
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert!(
        std::fs::read_dir(&cache).unwrap().count() > 0,
        "placements kept"
    );
    let mut expected: Vec<String> = Figure::ALL
        .iter()
        .flat_map(|f| ["png", "svg"].map(|ext| format!("{}.{ext}", f.file_stem())))
        .collect();
    expected.push("plots.json".into());
    expected.sort();
    assert_eq!(names, expected);
    for figure in Figure::ALL {
        assert_png(
            &out.join(format!("{}.png", figure.file_stem())),
            figure.size(),
        );
        assert_svg(&out.join(format!("{}.svg", figure.file_stem())));
    }
}
