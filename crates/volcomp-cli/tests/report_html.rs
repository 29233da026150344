//! The HTML reports: what they hold, that their figures are the ones the
//! commands print, that they are self-contained and reproducible, and (with
//! Debian's `chromium`) that the demo's report renders and prints.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common;
use common::{fixture, read, refused, stderr, tempdir, volcomp, write};

/// The HTML report `name` written in `dir`, checked self-contained.
#[track_caller]
fn report(dir: &Path, name: &str) -> String {
    let html = read(dir, name);
    assert_self_contained(&html);
    html
}

/// What the report must never hold: a script, or anything fetched from
/// outside the file (the SVG namespace is a name, not a fetch).
fn assert_self_contained(html: &str) {
    let without_ns = html.replace("xmlns=\"http://www.w3.org/2000/svg\"", "");
    for bad in [
        "http://", "https://", "src=", "<script", "<img", "<link", "url(",
    ] {
        assert!(!without_ns.contains(bad), "the report holds {bad:?}");
    }
}

/// The cell after `row` in the report's first table row starting with it.
fn cells(html: &str, row: &str) -> Vec<String> {
    let at = html
        .find(&format!("<td>{row}</td>"))
        .unwrap_or_else(|| panic!("no row {row}"));
    let end = at + html[at..].find("</tr>").unwrap();
    html[at..end]
        .split("<td")
        .skip(1)
        .map(|c| {
            let c = &c[c.find('>').unwrap() + 1..];
            c[..c.find("</td>").unwrap()].to_string()
        })
        .collect()
}

fn sha256sum(path: &Path) -> Option<String> {
    let o = Command::new("sha256sum").arg(path).output().ok()?;
    Some(
        String::from_utf8_lossy(&o.stdout)
            .split(' ')
            .next()?
            .to_string(),
    )
}

fn simulate_json(dir: &Path, args: &[&str]) -> serde_json::Value {
    let mut all = common::args("simulate --map map.csv --setup machine.toml --json");
    all.extend_from_slice(args);
    common::json(&volcomp(&all, dir))
}

#[test]
fn a_compensation_report_holds_the_runs_figures_and_inputs() {
    let dir = fixture("report-compensate");
    let run = |out: &str| {
        common::command(
            &dir,
            "compensate part.ngc --map map.csv --setup machine.toml -o part.comp.ngc --report-html",
        )
        .arg(out)
        .env("SOURCE_DATE_EPOCH", "86400")
        .output()
        .unwrap()
    };
    let o = run("report.html");
    common::ok(&o);
    let html = report(&dir, "report.html");
    // SOURCE_DATE_EPOCH = one day after the epoch.
    assert!(html.contains("1970-01-02T00:00:00Z"));
    // Every section, each a page of the print.
    for id in [
        "run",
        "results",
        "plan",
        "along",
        "histogram",
        "corrections",
    ] {
        assert!(html.contains(&format!("<section id=\"{id}\">")), "{id}");
    }
    // Plan view, contour and point error along the path, histogram; and,
    // as "after" is far below "before", its own plan view and curves on
    // their own scales.
    assert_eq!(html.matches("<svg").count(), 6);
    assert_eq!(html.matches("</svg>").count(), 6);
    // The sections are numbered in their headings and in the contents,
    // which print too; every printed page carries its number.
    assert!(html.contains("<section id=\"results\">\n<h2><span class=\"no\">1</span>"));
    assert!(html.contains("<section id=\"corrections\">\n<h2><span class=\"no\">5</span>"));
    assert!(html.contains("<nav class=\"contents\"><b>Contents</b><ol><li><a href=\"#results\">"));
    assert!(html.contains("counter(page) \" of \" counter(pages)"));
    // The metrics are defined once, on the first page.
    assert_eq!(html.matches("<td>contour error</td>").count(), 1);
    assert!(
        html.find("<td>contour error</td>").unwrap()
            < html.find("<section id=\"results\">").unwrap()
    );
    // No page for a warning the interpreter did not give.
    assert!(!html.contains("<section id=\"warnings\">"));
    // The inputs are named with their SHA-256, as sha256sum computes it.
    for f in ["part.ngc", "map.csv", "machine.toml"] {
        if let Some(sum) = sha256sum(&dir.join(f)) {
            assert!(html.contains(&sum), "{f} {sum}");
        }
    }
    // "before" is what `volcomp simulate` reports for the original,
    // "after" what it reports for the compensated program against it.
    let before = simulate_json(&dir, &["part.ngc"]);
    let after = simulate_json(&dir, &["part.comp.ngc", "--reference", "part.ngc"]);
    for (row, key) in [
        ("point error, RMS", "point_rms_um"),
        ("point error, max", "point_max_um"),
        ("contour error, RMS", "contour_rms_um"),
        ("contour error, max", "contour_max_um"),
    ] {
        let c = cells(&html, row);
        assert_eq!(
            c[1],
            format!("{:.3}", before[key].as_f64().unwrap()),
            "{row}"
        );
        assert_eq!(
            c[2],
            format!("{:.3}", after[key].as_f64().unwrap()),
            "{row}"
        );
    }
    // The program's lines are quoted beside the largest corrections: the
    // map grows with the position, so the largest correction is at the
    // largest coordinates: line 4 (G1 X60 Y40).
    assert!(
        html.contains("<td class=\"n\">4</td><td>G1 X60 Y40</td>"),
        "{html}"
    );
    // The same inputs and date give the same report, byte for byte.
    // The zoomed views' scale ends at what is left: the compensated
    // program's largest contour error, as `volcomp simulate` prints it.
    let zoom = html
        .split("alone on its own colour scale (0 to ")
        .nth(1)
        .and_then(|t| t.split(" µm)").next())
        .unwrap_or_else(|| panic!("no zoomed plan view"))
        .replace('−', "-");
    let zoom: f64 = zoom.parse().unwrap();
    let left = after["contour_max_um"].as_f64().unwrap();
    let shared = before["contour_max_um"].as_f64().unwrap();
    assert!(left < 0.2 * shared, "{left} {shared}");
    assert!(
        (zoom - left).abs() <= 1e-3 * left + 1e-6,
        "{zoom} vs {left}"
    );
    let o = run("again.html");
    common::ok(&o);
    let again = read(&dir, "again.html");
    assert_eq!(
        html.replace("report.html", "again.html"),
        again,
        "the report is not reproducible"
    );
}

#[test]
fn a_title_block_file_heads_the_report_and_a_bad_one_is_refused_at_its_line() {
    let dir = fixture("report-title");
    write(&dir, "title.toml", "customer = \"Acme Moulds & Dies\"\npart = \"cavity insert 4\"\ndrawing = \"D-1234\"\ntolerance = \"±0.01 mm\"\noperator = \"J. Smith\"\nmachine = \"VMC 2\"\n");
    let run = |title: &str, out: &str| {
        let html = format!("{out}.html");
        common::compensate_with(
            &dir,
            out,
            &["--report-html", &html, "--report-title", title],
        )
    };
    let o = run("title.toml", "c.ngc");
    common::ok(&o);
    let html = read(&dir, "c.ngc.html");
    // In the report's order, escaped, above what was done.
    let block = html
        .split("<table class=\"titleblock\"><tbody>")
        .nth(1)
        .and_then(|t| t.split("</tbody>").next())
        .expect("a title block");
    assert_eq!(
        block,
        "<tr><th>customer</th><td>Acme Moulds &amp; Dies</td></tr><tr><th>part</th><td>cavity insert 4</td></tr><tr><th>drawing</th><td>D-1234</td></tr><tr><th>machine</th><td>VMC 2</td></tr><tr><th>tolerance</th><td>±0.01 mm</td></tr><tr><th>operator</th><td>J. Smith</td></tr>"
    );
    assert!(html.find("titleblock").unwrap() < html.find("What was done").unwrap());
    // A misspelt key: refused at its line and column before any work,
    // nothing written.
    write(&dir, "bad.toml", "customer = \"A\"\n  custmer = \"B\"\n");
    let o = run("bad.toml", "d.ngc");
    let e = refused(&o);
    assert!(
        e.contains("bad.toml:2:3: `custmer` is not a title-block key"),
        "{e}"
    );
    assert!(!dir.join("d.ngc").exists() && !dir.join("d.ngc.html").exists());
    // A title block without a report is refused, not ignored; the
    // message names the flags.
    let e = refused(&common::run(
        &dir,
        "simulate part.ngc --map map.csv --report-title title.toml",
    ));
    assert!(
        e.contains("--report-title is the title block of the HTML report"),
        "{e}"
    );
}

#[test]
fn a_report_needs_the_program_as_a_file_and_never_overwrites_an_input() {
    let dir = fixture("report-refusals");
    let o = common::run(
        &dir,
        "compensate - --map map.csv -o x.ngc --report-html r.html",
    );
    assert!(!o.status.success());
    common::said(&o, "--report-html");
    assert!(!dir.join("r.html").exists() && !dir.join("x.ngc").exists());
    let before = std::fs::read(dir.join("part.ngc")).unwrap();
    let o = common::run(
        &dir,
        "simulate part.ngc --map map.csv --report-html part.ngc",
    );
    assert!(!o.status.success());
    assert_eq!(std::fs::read(dir.join("part.ngc")).unwrap(), before);
}

#[test]
fn a_simulation_report_with_a_reference_shows_both() {
    let dir = fixture("report-simulate");
    common::run_all(
        &dir,
        &[
            "compensate part.ngc --map map.csv --setup machine.toml -o c.ngc",
            "simulate c.ngc --reference part.ngc --map map.csv --setup machine.toml --report-html sim.html",
        ],
    );
    let html = report(&dir, "sim.html");
    let reference = simulate_json(&dir, &["part.ngc"]);
    let c = cells(&html, "contour error, max");
    assert_eq!(
        c[1],
        format!("{:.3}", reference["contour_max_um"].as_f64().unwrap())
    );
    // Two panels on one colour scale: one colour bar.
    assert!(html.contains(">part.ngc</text>") && html.contains(">c.ngc</text>"));
}

fn chromium() -> Option<PathBuf> {
    for name in ["chromium", "chromium-browser"] {
        let o = Command::new("sh")
            .args(["-c", &format!("command -v {name}")])
            .output()
            .ok()?;
        if o.status.success() {
            let p = String::from_utf8_lossy(&o.stdout).trim().to_string();
            if !p.is_empty() {
                return Some(PathBuf::from(p));
            }
        }
    }
    None
}

/// Chromium without a desktop: no network, no profile left behind.
/// Headless Chromium, with its own profile in `profile`, opens `report` and
/// writes `out` (`what` is the flag that names it, e.g. `--screenshot`);
/// the run must succeed and write it.
fn headless(chromium: &Path, profile: &Path, report: &Path, what: &str, out: &Path, extra: &str) {
    let o = Command::new(chromium)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-first-run",
            "--hide-scrollbars",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(format!("{what}={}", out.display()))
        .arg(extra)
        .arg(format!("file://{}", report.display()))
        .output()
        .unwrap();
    assert!(o.status.success() && out.exists(), "{}", stderr(&o));
}

#[test]
fn the_demo_report_renders_and_prints_in_chromium() {
    let dir = tempdir("demo-report");
    let stdout = common::ok(&common::run(&dir, "demo --out-dir demo"));
    assert!(stdout.contains("demo/report.html"), "{stdout}");
    let report = dir.join("demo/report.html");
    let html = std::fs::read_to_string(&report).unwrap();
    assert_self_contained(&html);
    // The overview, then five sections per program.
    let programs = html.matches("<td>program</td>").count();
    assert!(programs >= 2, "{programs}");
    let sections = html.matches("<section id=").count();
    assert_eq!(sections, 2 + 5 * programs);
    for kind in ["results", "plan", "along", "histogram", "corrections"] {
        assert_eq!(
            html.matches(&format!("-{kind}\">\n<h2>")).count(),
            programs,
            "{kind}"
        );
    }
    let Some(chromium) = chromium() else {
        common::missing(
            "chromium (Debian package chromium)",
            "the demo report rendered and printed",
        );
        return;
    };
    let profile = dir.join("profile");
    let png = dir.join("report.png");
    let size = "--window-size=900,1400";
    headless(&chromium, &profile, &report, "--screenshot", &png, size);
    // Non-blank: the first page has text, tables and links in colour.
    let img = image::open(&png).unwrap().to_rgb8();
    assert_eq!((img.width(), img.height()), (900, 1400));
    let ink = img
        .pixels()
        .filter(|p| p.0.iter().any(|c| *c < 200))
        .count();
    let share = ink as f64 / (900.0 * 1400.0);
    assert!(share > 0.01 && share < 0.6, "ink {share}");
    let pdf = dir.join("report.pdf");
    let no_header = "--no-pdf-header-footer";
    headless(
        &chromium,
        &profile,
        &report,
        "--print-to-pdf",
        &pdf,
        no_header,
    );
    let bytes = std::fs::read(&pdf).unwrap();
    // Page objects: `/Type /Page` not followed by `s` (that is `/Pages`).
    let text = String::from_utf8_lossy(&bytes).replace("/Type/Page", "/Type /Page");
    let pages = text
        .match_indices("/Type /Page")
        .filter(|(i, _)| !text[i + 11..].starts_with('s'))
        .count();
    // Every section starts a page; none needs more than two.
    assert!(
        pages >= sections && pages <= 2 * sections,
        "{pages} pages for {sections} sections"
    );
    // Every printed page says its number and the report's title in its
    // margin (@page margin boxes); the contents are printed on the first.
    let texts = common::pdf::page_texts(&bytes);
    assert_eq!(texts.len(), pages);
    for (k, t) in texts.iter().enumerate() {
        assert!(
            t.contains(&format!("page {} of {pages}", k + 1)),
            "page {}: {t}",
            k + 1
        );
        assert!(t.contains("volcomp demo report"), "page {}: {t}", k + 1);
    }
    assert!(texts[0].contains("Contents"), "{}", texts[0]);
    assert!(
        texts[0].contains("Point and contour error") || texts[0].contains("contour error"),
        "{}",
        texts[0]
    );
}

#[test]
fn a_positioning_test_report_has_the_bidirectional_plot_and_figures() {
    let dir = tempdir("report-iso");
    let runs = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data/runs.csv");
    std::fs::copy(&runs, dir.join("runs.csv")).unwrap();
    let json = common::json(&common::run(
        &dir,
        "map iso230-2 runs.csv --axis X --report-html iso.html --json",
    ));
    let html = report(&dir, "iso.html");
    for id in ["run", "iso230-2", "iso230-2-targets"] {
        assert!(html.contains(&format!("<section id=\"{id}\">")), "{id}");
    }
    // The figures are the evaluation's (printed by --json), to the µm/1000.
    let a = &json["axis"];
    let cell = |row: &str| cells(&html, row);
    assert_eq!(
        cell("A accuracy of positioning")[3],
        format!("{:.3}", a["accuracy_um"].as_f64().unwrap())
    );
    assert_eq!(
        cell("E systematic positional deviation")[1],
        format!("{:.3}", a["systematic_up_um"].as_f64().unwrap())
    );
    assert!(html.contains("positional deviation x = P − Pᵢ (µm)"));
}

#[test]
fn a_map_report_draws_every_component_over_its_axis() {
    let dir = tempdir("report-map");
    common::run_all(
        &dir,
        &[
            "map example -o models",
            "map plot models/example21.toml -o map.html",
        ],
    );
    let html = report(&dir, "map.html");
    // Three axes, each a page with its linear (µm) and angular (µrad) chart.
    assert_eq!(html.matches("<section id=\"map-").count(), 3);
    assert_eq!(html.matches("<svg").count(), 6);
    assert_eq!(html.matches(">error (µm)</text>").count(), 3);
    assert_eq!(html.matches(">rotation (µrad)</text>").count(), 3);
    // The 18 components of the three axes (squareness is in the titles);
    // the example's positioning errors differ by direction: drawn apart.
    for axis in ["X", "Y", "Z"] {
        for c in ["X", "Y", "Z", "A", "B", "C"] {
            let name = format!("E{c}{axis}");
            let alone = html.contains(&format!(">{name}</text>"));
            let apart = html.contains(&format!(">{name} forward</text>"))
                && html.contains(&format!(">{name} reverse</text>"));
            assert!(alone || apart, "{name}");
        }
    }
}

#[test]
fn straightness_and_thermal_reports_keep_units_apart_and_wavelengths_in_mm() {
    let dir = tempdir("report-charts");
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data/runs");
    std::fs::create_dir_all(dir.join("runs")).unwrap();
    let mut runs = Vec::new();
    for e in std::fs::read_dir(&data).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if name.starts_with("x-") && name.ends_with(".csv") {
            std::fs::copy(&p, dir.join("runs").join(&name)).unwrap();
            runs.push(format!("runs/{name}"));
        }
    }
    assert!(runs.len() >= 2, "{runs:?}");
    let mut args = vec!["straightness", "plot"];
    args.extend(runs.iter().map(String::as_str));
    args.extend(["-o", "st.html"]);
    let o = volcomp(&args, &dir);
    common::ok(&o);
    let html = report(&dir, "st.html");
    assert!(!html.contains("log₁₀"));
    assert!(html.contains(">wavelength λ (mm, logarithmic)</text>"));
    // Decade ticks in mm: 1 mm and 10 mm are labelled as such.
    assert!(html.contains(">1</text>") && html.contains(">10</text>"));
    // Every input named with its SHA-256.
    for r in &runs {
        assert!(html.contains(&format!("<td>{r}</td>")), "{r}");
    }

    common::run_all(
        &dir,
        &[
            "thermal example -o ex",
            "thermal fit --measurements ex/measurements_train.csv --temperatures ex/temperatures_train.csv --artifact ex/artifact.csv --ranges-mm 0:600,0:400,0:300 -o thermal.toml",
            "thermal plot --model thermal.toml -o th.html",
        ],
    );
    let html = report(&dir, "th.html");
    // No axis mixes µm and µrad; both have their own charts.
    assert!(!html.contains("µm or µrad"));
    let axis_labels: Vec<&str> = html
        .split("transform=\"rotate(-90")
        .skip(1)
        .map(|s| &s[s.find('>').unwrap() + 1..s.find("</text>").unwrap()])
        .collect();
    assert!(
        axis_labels.iter().any(|l| l.contains("(µm)")),
        "{axis_labels:?}"
    );
    assert!(
        axis_labels.iter().any(|l| l.contains("(µrad)")),
        "{axis_labels:?}"
    );
    assert!(axis_labels
        .iter()
        .all(|l| !(l.contains("µm") && l.contains("µrad"))));
    assert!(
        axis_labels.iter().all(|l| l.contains('(')),
        "a unit missing: {axis_labels:?}"
    );
}

#[test]
fn a_mirror_report_has_the_statistics_and_the_probe_points() {
    let dir = tempdir("report-mirror");
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data");
    for f in ["face.toml", "probes.csv", "finish.ngc"] {
        std::fs::copy(data.join(f), dir.join(f)).unwrap();
    }
    let run = |extra: &[&str], out: &str| {
        let mut args: Vec<&str> = "surface mirror --nominal face.toml --measured probes.csv --stock 0.2 --finishing finish.ngc --tool-radius 3 -o"
            .split_whitespace()
            .collect();
        args.push(out);
        args.extend_from_slice(extra);
        let o = volcomp(&args, &dir);
        common::ok(&o);
        o
    };
    run(&["--report", "mirror.html"], "a.ngc");
    let o = run(&["--json"], "b.ngc");
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let html = report(&dir, "mirror.html");
    for id in ["run", "mirror", "mirror-points"] {
        assert!(html.contains(&format!("<section id=\"{id}\">")), "{id}");
    }
    // The statistics are those of the summary (--json), to the nm.
    let row = cells(&html, "measured (no compensation)");
    let before = &json["before"];
    assert_eq!(row[1], before["count"].to_string());
    assert_eq!(row[3], format!("{:.3}", before["std_um"].as_f64().unwrap()));
    assert_eq!(
        row[6],
        format!("{:.3}", before["profile_um"].as_f64().unwrap())
    );
    // One dot per probe point.
    let dots = html.matches(" L").count();
    assert!(dots >= before["count"].as_u64().unwrap() as usize);
    assert!(html.contains("semi-finishing error (µm)"));
}
