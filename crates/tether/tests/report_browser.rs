//! The demo's `report.html` and `tether replay`'s report render in a real browser:
//! headless Chromium takes a screenshot of each, and the picture shows the page (not a
//! blank or an error page); the replay report's DOM, as Chromium parsed it, holds the
//! snapshots, the scale bars and the track table.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly")]

use std::path::Path;
use std::process::{Command, Output};

fn chromium() -> Option<&'static str> {
    ["chromium", "chromium-browser", "google-chrome"]
        .into_iter()
        .find(|c| {
            Command::new(c)
                .arg("--version")
                .output()
                .is_ok_and(|o| o.status.success())
        })
}

/// Chromium, or `None` (and the test skips, unless `TETHER_REQUIRE_SHARED=1`).
fn chromium_or_skip() -> Option<&'static str> {
    let browser = chromium();
    if browser.is_none() {
        assert!(
            std::env::var("TETHER_REQUIRE_SHARED").as_deref() != Ok("1"),
            "no Chromium (apt-get install chromium); TETHER_REQUIRE_SHARED=1 demands that this test runs"
        );
        eprintln!("SKIPPED: no Chromium found (apt-get install chromium)");
    }
    browser
}

/// Headless Chromium on `html` with a fresh profile in `dir`, and `extra` arguments.
fn headless(browser: &str, dir: &Path, html: &Path, extra: &[String]) -> Output {
    Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--hide-scrollbars",
        ])
        .arg(format!("--user-data-dir={}", dir.join("profile").display()))
        .args(extra)
        .arg(format!("file://{}", html.display()))
        .output()
        .unwrap()
}

#[test]
fn report_renders_in_headless_chromium() {
    let Some(browser) = chromium_or_skip() else {
        return;
    };
    let dir = std::env::temp_dir().join(format!("tether-report-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = Command::new(env!("CARGO_BIN_EXE_tether"))
        .args([
            "demo",
            "--scenario",
            "corridor",
            "--out",
            dir.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let html = dir.join("report.html");
    let text = std::fs::read_to_string(&html).unwrap();
    // Self-contained: inline SVG, nothing fetched.
    assert!(text.contains("<svg"));
    assert!(
        !text.contains("src=\"http") && !text.contains("href=\"http"),
        "no network resources"
    );
    assert!(!text.contains("<script"), "self-contained: no scripts");
    let png = dir.join("shot.png");
    let shot = headless(
        browser,
        &dir,
        &html,
        &[
            "--window-size=1100,1800".to_owned(),
            format!("--screenshot={}", png.display()),
        ],
    );
    assert!(
        png.is_file(),
        "no screenshot: {}",
        String::from_utf8_lossy(&shot.stderr)
    );
    let img = tether_vision::imread::imread_gray(&png).unwrap();
    let pixels = img.pixels();
    let dark = pixels.iter().filter(|p| **p < 128).count() as f64 / pixels.len() as f64;
    let distinct = {
        let mut seen = [false; 256];
        pixels.iter().for_each(|p| seen[*p as usize] = true);
        seen.iter().filter(|s| **s).count()
    };
    println!(
        "screenshot {}x{}: {:.1} % dark pixels, {distinct} grey levels",
        img.width(),
        img.height(),
        100.0 * dark
    );
    // Text, tables, plots and the map: some ink, many grey levels; not a blank page.
    assert!(dark > 0.005 && dark < 0.5, "{dark}");
    assert!(distinct > 40, "{distinct}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Runs `tether` with `args`, which must succeed.
fn tether_ok(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_tether"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "tether {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn replay_report_renders_in_headless_chromium() {
    let Some(browser) = chromium_or_skip() else {
        return;
    };
    let dir = std::env::temp_dir().join(format!("tether-replay-report-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let record = dir.join("run.mcap");
    tether_ok(&[
        "sim",
        "--scenario",
        "crossing",
        "--out",
        dir.join("sim").to_str().unwrap(),
        "--record",
        record.to_str().unwrap(),
    ]);
    let result = dir.join("r.mcap");
    tether_ok(&[
        "replay",
        record.to_str().unwrap(),
        "--out",
        result.to_str().unwrap(),
    ]);
    let html = dir.join("r.html");
    let text = std::fs::read_to_string(&html).unwrap();
    assert!(
        !text.contains("src=\"http") && !text.contains("href=\"http"),
        "no network resources"
    );
    assert!(!text.contains("<script"), "self-contained: no scripts");

    // The DOM as Chromium parsed it.
    let dom = headless(browser, &dir, &html, &["--dump-dom".to_owned()]);
    let dom = String::from_utf8_lossy(&dom.stdout);
    let snapshots = dom.matches("<figure class=\"snapshot\"").count();
    println!(
        "DOM: {} bytes, {snapshots} snapshot figures, {} scale bars",
        dom.len(),
        dom.matches("class=\"scale-bar\"").count()
    );
    // 14 s of `crossing`, no loss of the target: eight evenly spaced snapshots.
    assert_eq!(snapshots, 8, "{dom}");
    assert_eq!(dom.matches("<figcaption").count(), snapshots);
    assert!(dom.contains("S1 · t = ") && dom.contains("evenly spaced"));
    // Each snapshot and the map: axes and a scale bar.
    assert_eq!(dom.matches("class=\"scale-bar\"").count(), snapshots + 1);
    assert_eq!(dom.matches("class=\"axes\"").count(), snapshots + 1);
    assert!(dom.contains("x (m, scan_odom)"));
    // What a snapshot draws: returns, legs, people, tracks, the target, the robot.
    for class in ["scan", "leg", "person", "track", "target", "robot"] {
        assert!(
            dom.contains(&format!("class=\"{class}\"")),
            "no {class} in the snapshots"
        );
    }
    // The track table: the target's track among the rows.
    let table = dom
        .split("<table class=\"tracks\">")
        .nth(1)
        .and_then(|t| t.split("</table>").next())
        .expect("the track table");
    assert!(table.matches("<tr>").count() >= 2, "{table}");
    assert!(table.contains("yes"), "the target's track: {table}");

    // The picture.
    let png = dir.join("shot.png");
    let shot = headless(
        browser,
        &dir,
        &html,
        &[
            "--window-size=1400,4000".to_owned(),
            format!("--screenshot={}", png.display()),
        ],
    );
    assert!(
        png.is_file(),
        "no screenshot: {}",
        String::from_utf8_lossy(&shot.stderr)
    );
    let img = tether_vision::imread::imread_gray(&png).unwrap();
    assert_eq!((img.width(), img.height()), (1400, 4000));
    let pixels = img.pixels();
    let at = |x: usize, y: usize| pixels[y * img.width() + x];
    // White margins and page.
    for (x, y) in [(2, 2), (1397, 2), (2, 3997), (1397, 3997), (700, 2)] {
        assert!(at(x, y) > 240, "pixel ({x}, {y}) is {}", at(x, y));
    }
    // Ink all the way down: the map, eight snapshots in four rows, the tables and the
    // plots fill the first 3,500 px (every 500-px band has some dark pixels).
    for band in 0..7 {
        let rows = &pixels[band * 500 * 1400..(band + 1) * 500 * 1400];
        let dark = rows.iter().filter(|p| **p < 128).count() as f64 / rows.len() as f64;
        println!("band {band}: {:.2} % dark", 100.0 * dark);
        assert!(dark > 0.001 && dark < 0.3, "band {band}: {dark}");
    }
    let distinct = {
        let mut seen = [false; 256];
        pixels.iter().for_each(|p| seen[*p as usize] = true);
        seen.iter().filter(|s| **s).count()
    };
    assert!(distinct > 40, "{distinct}");
    let _ = std::fs::remove_dir_all(&dir);
}
