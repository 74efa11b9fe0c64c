//! The figures and report.html of a small catalogue study as a design
//! review reads them: every PNG with its SVG, the chosen combination's pose
//! count named in every grade figure, bands that do not overlap into one
//! colour, the workspace target readable, the set-up on the page.

mod common;

use common::*;
use std::path::{Path, PathBuf};
use tempfile::TempDir;

/// A catalogue study of 2 encoders × 3 scales × 9 or 51 poses, judged over
/// the workspace with a loose target, so that a 9-pose combination is
/// chosen (the cheapest pass, then the fewest poses).
fn study(dir: &Path) -> PathBuf {
    let cat = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/sensors.toml");
    let cfg = write(
        dir,
        "study.toml",
        &format!(
            "[identification]\nmethod = \"wls\"\n[sweep]\ncatalogue = \"{}\"\nencoders = [\"angle-1as-d200\", \"angle-5as-d60\"]\nscales = [\"lin-1um-sp4\", \"lin-2um-sp4\", \"lin-5um-sp20\"]\npose_counts = [9, 51]\nmethods = [\"wls\"]\ntrials = 100\nvolumetric = true\n[decision]\nmetric = \"dv_after_p95_p95\"\nthreshold = 0.5\n",
            cat.display()
        ),
    );
    let out = dir.join("out");
    bin()
        .args(["sweep", "--no-trials", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    out
}

/// The chosen row's pose count in decision.csv.
fn chosen_pose_count(out: &Path) -> usize {
    let mut r = csv::Reader::from_path(out.join("decision.csv")).unwrap();
    let h = r.headers().unwrap().clone();
    let col = |n: &str| h.iter().position(|c| c == n).unwrap();
    r.records()
        .map(|x| x.unwrap())
        .find(|x| &x[col("chosen")] == "true")
        .map(|x| x[col("pose_count")].parse().unwrap())
        .expect("a combination is chosen")
}

fn svg(out: &Path, name: &str) -> String {
    std::fs::read_to_string(out.join(name)).unwrap()
}

#[test]
fn a_catalogue_study_writes_figures_a_reviewer_can_read() {
    let t = TempDir::new().unwrap();
    let out = study(t.path());
    // Every figure as PNG and SVG (parameters and workspace had no SVG).
    assert_every_png_has_its_svg(&out);
    for f in [
        "parameters.svg",
        "workspace.svg",
        "fig4.svg",
        "grade_map.svg",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    // The figures show the chosen combination's pose count, not the largest.
    let n = chosen_pose_count(&out);
    assert_eq!(n, 9, "the study is built for a 9-pose choice");
    let shown = format!("{n} poses (the chosen combination&apos;s)");
    for f in [
        "fig4.svg",
        "workspace.svg",
        "grade_map.svg",
        "parameters.svg",
    ] {
        let s = svg(&out, f);
        assert!(s.contains(&shown), "{f} does not say it shows {shown}");
        assert!(!s.contains("51 poses"), "{f} shows 51 poses");
    }
    // Three scales a panel: bands as dashed edges, no overlapping fills.
    for f in ["fig4.svg", "workspace.svg"] {
        let s = svg(&out, f);
        assert!(!s.contains("<polygon"), "{f} still fills its bands");
        assert!(s.contains("95 % of machines below, scale 5 µm"), "{f}");
    }
    // The workspace target is tagged with its value in mm.
    assert!(svg(&out, "workspace.svg").contains("target 0.5 mm"));
    // The grade map's colour bar says its scale and marks the target.
    assert!(svg(&out, "grade_map.svg").contains("log colour scale"));
    // The price axis has its unit; the budget's outline is the chosen one's.
    assert!(svg(&out, "price_accuracy.svg").contains("currency units"));
    assert!(svg(&out, "budget.svg").contains("black outline: the chosen combination"));
    // The page's set-up: geometry, workspace and grid step, in mm.
    let page = std::fs::read_to_string(out.join("report.html")).unwrap();
    for needle in [
        "<dt>geometry</dt>",
        "platform circumradius a = 100 mm, base circumradius b = 288.7 mm",
        "<dt>workspace</dt>",
        "cylinder of radius 400 mm and height 200 mm",
        "grid step 100 mm on 5 planes",
    ] {
        assert!(page.contains(needle), "report.html lacks {needle}");
    }
}
