//! The demo's `report.html` renders in a real browser: headless Chromium takes a
//! screenshot of it, and the picture shows the page (not a blank or an error page).

#![allow(clippy::unwrap_used, reason = "a test should fail loudly")]

use std::process::Command;

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

#[test]
fn report_renders_in_headless_chromium() {
    let Some(browser) = chromium() else {
        assert!(
            std::env::var("TETHER_REQUIRE_SHARED").as_deref() != Ok("1"),
            "no Chromium (apt-get install chromium); TETHER_REQUIRE_SHARED=1 demands that this test runs"
        );
        eprintln!("SKIPPED: no Chromium found (apt-get install chromium)");
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
    let shot = Command::new(browser)
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
            "--window-size=1100,1800",
        ])
        .arg(format!("--user-data-dir={}", dir.join("profile").display()))
        .arg(format!("--screenshot={}", png.display()))
        .arg(format!("file://{}", html.display()))
        .output()
        .unwrap();
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
