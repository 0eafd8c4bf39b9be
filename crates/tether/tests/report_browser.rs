//! The demo's `report.html` and `tether replay`'s report render in a real browser:
//! headless Chromium takes a screenshot of each, and the picture shows the page (not a
//! blank or an error page); the replay report's DOM, as Chromium parsed it, holds the
//! snapshots, the scale bars and the track table. The demo report's DOM holds the
//! insets of "what fusion buys", and Chromium's own layout of it (measured by a small
//! script in a copy of the page) has every map, plot and inset within the page, at a
//! wide and at a narrow window, and no two time labels of a plot or labels of a map
//! overlapping.
//!
//! The demo report of every scenario, and the replay report, are measured whole: the
//! bounding boxes of every text of every picture (axis titles, tick labels, legend
//! entries, inset labels, time labels, annotations) as Chromium lays them out, pair by
//! pair within each picture, none overlapping another; no two entries of a legend in
//! one colour; no label of a map on a magnified view's square; and in the replay
//! report, every mark drawn in a snapshot or on the map found in its legend.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly")]

use std::path::Path;
use std::process::{Command, Output};

use serde_json::Value;

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
    tether_testkit::skip_unless(
        browser.is_some(),
        "no Chromium found (apt-get install chromium)",
    );
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

/// A screenshot of `html` in a `width` x `height` window, as grey pixels; fails the
/// test when Chromium wrote none.
fn screenshot(
    browser: &str,
    dir: &Path,
    html: &Path,
    width: usize,
    height: usize,
) -> tether_core::GrayImage {
    let png = dir.join("shot.png");
    let shot = headless(
        browser,
        dir,
        html,
        &[
            format!("--window-size={width},{height}"),
            format!("--screenshot={}", png.display()),
        ],
    );
    assert!(
        png.is_file(),
        "no screenshot: {}",
        String::from_utf8_lossy(&shot.stderr)
    );
    tether_image::imread_gray(&png).unwrap()
}

/// How many grey levels `pixels` use.
fn grey_levels(pixels: &[u8]) -> usize {
    let mut seen = [false; 256];
    pixels.iter().for_each(|p| seen[*p as usize] = true);
    seen.iter().filter(|s| **s).count()
}

/// The page fetches nothing and runs no script.
fn assert_self_contained(text: &str) {
    assert!(
        !text.contains("src=\"http") && !text.contains("href=\"http"),
        "no network resources"
    );
    assert!(!text.contains("<script"), "self-contained: no scripts");
}

#[test]
fn report_renders_in_headless_chromium() {
    let Some(browser) = chromium_or_skip() else {
        return;
    };
    let dir = std::env::temp_dir().join(format!("tether-report-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    tether_ok(&[
        "demo",
        "--scenario",
        "corridor",
        "--out",
        dir.to_str().unwrap(),
    ]);
    let html = dir.join("report.html");
    let text = std::fs::read_to_string(&html).unwrap();
    // Self-contained: inline SVG, nothing fetched.
    assert!(text.contains("<svg"));
    assert_self_contained(&text);
    let img = screenshot(browser, &dir, &html, 1100, 1800);
    let pixels = img.pixels();
    let dark = pixels.iter().filter(|p| **p < 128).count() as f64 / pixels.len() as f64;
    let distinct = grey_levels(pixels);
    println!(
        "screenshot {}x{}: {:.1} % dark pixels, {distinct} grey levels",
        img.width(),
        img.height(),
        100.0 * dark
    );
    // Text, tables, plots and the map: some ink, many grey levels; not a blank page.
    assert!(dark > 0.005 && dark < 0.5, "{dark}");
    assert!(distinct > 40, "{distinct}");
    demo_dom_has_the_insets(browser, &dir, &html);
    for width in [1400, 820] {
        demo_layout_fits(browser, &dir, &text, width);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The value of attribute `name` in the start tag that `tag` begins.
fn attr<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
    let head = tag.split('>').next()?;
    head.split(&format!(" {name}=\"")).nth(1)?.split('"').next()
}

/// The texts of the `<text>` elements in `svg`.
fn texts(svg: &str) -> Vec<&str> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| t.split('>').nth(1)?.split('<').next())
        .collect()
}

/// The corridor's demo report as Chromium parsed it: the fused run has three insets
/// (laser-only, vision-only and fused ellipses at one scale, a scale bar, a legend
/// whose every entry has text, a caption), marked on its map; the laser-only run says
/// why it has none; every plot's time labels, by their x and a width estimated from
/// their characters, stand apart.
fn demo_dom_has_the_insets(browser: &str, dir: &Path, html: &Path) {
    let dom = headless(browser, dir, html, &["--dump-dom".to_owned()]);
    let dom = String::from_utf8_lossy(&dom.stdout).into_owned();
    let figures: Vec<&str> = dom
        .split("<figure class=\"inset\"")
        .skip(1)
        .map(|f| f.split("</figure>").next().unwrap())
        .collect();
    println!(
        "demo DOM: {} bytes, {} insets, {} zoom boxes, {} plots",
        dom.len(),
        figures.len(),
        dom.matches("class=\"zoom-box\"").count(),
        dom.matches("<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"plot\"")
            .count()
    );
    assert_eq!(figures.len(), 3, "three insets in the fused corridor run");
    assert_eq!(dom.matches("class=\"zoom-box\"").count(), 3);
    assert!(dom.contains("magnified below (A, B, C)"));
    assert_eq!(
        dom.matches("class=\"no-insets\"").count(),
        1,
        "corridor-laser-only"
    );
    for (figure, letter) in figures.iter().zip(["A", "B", "C"]) {
        let svg = figure.split("</svg>").next().unwrap();
        assert!(svg.contains("class=\"inset-zoom\""), "{figure}");
        // The laser's, the camera's and the fused ellipse, and one each in the legend.
        assert_eq!(svg.matches("<ellipse").count(), 6, "{letter}: {svg}");
        for color in ["#1f77b4", "#2ca02c", "#9467bd"] {
            assert!(
                svg.contains(&format!("stroke=\"{color}\"")),
                "{letter}: {color}"
            );
        }
        assert!(svg.contains("class=\"scale-bar\"") && svg.contains("class=\"truth\""));
        let legend: Vec<&str> = svg.split("class=\"legend-entry\"").skip(1).collect();
        assert_eq!(legend.len(), 5, "{letter}");
        for entry in legend {
            let text = texts(entry);
            assert!(
                text.first().is_some_and(|t| !t.trim().is_empty()),
                "{letter}: a legend entry without text: {entry}"
            );
        }
        // Each ellipse at least MIN_ELLIPSE_PX (40 px) wide.
        for e in svg.split("<ellipse").skip(1).take(3) {
            let rx: f64 = attr(e, "rx").unwrap().parse().unwrap();
            let ry: f64 = attr(e, "ry").unwrap().parse().unwrap();
            assert!(2.0 * rx.max(ry) >= 39.9, "{letter}: {rx} x {ry} px");
        }
        let caption = figure.split("<figcaption>").nth(1).unwrap();
        assert!(
            caption.starts_with(&format!("<b>{letter}</b> · t = ")),
            "{caption}"
        );
        assert!(caption.contains("Half-axes (2σ): laser "), "{caption}");
    }
    // Every legend entry of every plot has text.
    let plots: Vec<&str> = dom
        .split("class=\"plot\"")
        .skip(1)
        .map(|p| p.split("</svg>").next().unwrap())
        .collect();
    assert!(plots.len() >= 6, "{}", plots.len());
    for plot in &plots {
        for entry in plot.split("class=\"legend-entry\"").skip(1) {
            assert!(
                texts(entry).first().is_some_and(|t| !t.trim().is_empty()),
                "a plot's legend entry without text: {entry}"
            );
        }
        // Time labels: 11 px text, at most 7 px a character, centred on their x.
        let mut labels: Vec<(f64, f64)> = plot
            .split("<text class=\"tick-x\"")
            .skip(1)
            .map(|t| {
                let x: f64 = attr(t, "x").unwrap().parse().unwrap();
                let text = t.split('>').nth(1).unwrap().split('<').next().unwrap();
                (x, 7.0 * text.chars().count() as f64)
            })
            .collect();
        assert!(labels.len() >= 3, "{plot}");
        labels.sort_by(|a, b| a.0.total_cmp(&b.0));
        for pair in labels.windows(2) {
            let ((a, wa), (b, wb)) = (pair[0], pair[1]);
            assert!(
                b - a >= (wa + wb) / 2.0,
                "time labels at {a} and {b} overlap"
            );
        }
    }
}

/// What the measuring script finds in Chromium's layout of the page.
const MEASURE: &str = r#"<script>
(function () {
  const body = document.body.getBoundingClientRect();
  const out = { page: [body.left, body.right], view: document.documentElement.clientWidth,
                figures: [], overlaps: [] };
  for (const svg of document.querySelectorAll("svg.map, svg.plot, svg.inset-zoom")) {
    const r = svg.getBoundingClientRect();
    const vb = svg.viewBox.baseVal;
    out.figures.push({ kind: svg.getAttribute("class"), left: r.left, right: r.right,
                       width: r.width, height: r.height, vb: [vb.width, vb.height] });
  }
  const apart = (svg, selector, what) => {
    const boxes = [...svg.querySelectorAll(selector)].map(t => [t.textContent, t.getBoundingClientRect()]);
    for (let i = 0; i < boxes.length; i++) {
      for (let j = i + 1; j < boxes.length; j++) {
        const [ta, a] = boxes[i], [tb, b] = boxes[j];
        if (a.left < b.right && b.left < a.right && a.top < b.bottom && b.top < a.bottom) {
          out.overlaps.push(what + ": " + ta + " / " + tb);
        }
      }
    }
    return boxes.length;
  };
  out.ticks = 0;
  for (const svg of document.querySelectorAll("svg.plot")) { out.ticks += apart(svg, "text.tick-x", "time labels"); }
  out.map_labels = 0;
  for (const svg of document.querySelectorAll("svg.map")) { out.map_labels += apart(svg, "text.map-label", "map labels"); }
  const pre = document.createElement("pre");
  pre.id = "layout";
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
})();
</script>"#;

/// The JSON that `script` (added to a copy of the page `html_text`) writes into its
/// `<pre id="ID">`, from Chromium's layout of the page `width` px wide, as the DOM has it
/// (entities still escaped).
fn measured_json(
    browser: &str,
    dir: &Path,
    html_text: &str,
    width: u32,
    script: &str,
    id: &str,
) -> String {
    let measured = dir.join(format!("{id}-{width}.html"));
    std::fs::write(
        &measured,
        html_text.replace("</body>", &format!("{script}</body>")),
    )
    .unwrap();
    let dom = headless(
        browser,
        dir,
        &measured,
        &[
            format!("--window-size={width},1200"),
            "--dump-dom".to_owned(),
        ],
    );
    let dom = String::from_utf8_lossy(&dom.stdout);
    dom.split(&format!("<pre id=\"{id}\">"))
        .nth(1)
        .and_then(|t| t.split("</pre>").next())
        .unwrap_or_else(|| {
            panic!(
                "nothing measured into #{id}: {}",
                &dom[..dom.len().min(2000)]
            )
        })
        .to_owned()
}

/// The page laid out by Chromium in a window `width` px wide: every map, plot and
/// inset lies within the page's body (shrunk to fit when the window is narrow, its
/// shape kept), and no two time labels of a plot nor labels of a map overlap.
fn demo_layout_fits(browser: &str, dir: &Path, html_text: &str, width: u32) {
    let json = measured_json(browser, dir, html_text, width, MEASURE, "layout");
    let layout: Value = serde_json::from_str(&json.replace("&quot;", "\"")).unwrap();
    let (left, right) = (
        layout["page"][0].as_f64().unwrap(),
        layout["page"][1].as_f64().unwrap(),
    );
    let figures = layout["figures"].as_array().unwrap();
    let count = |kind: &str| figures.iter().filter(|f| f["kind"] == kind).count();
    println!(
        "layout at {width} px: page {left:.0}..{right:.0}, {} maps, {} plots, {} insets, {} time labels, {} map labels",
        count("map"),
        count("plot"),
        count("inset-zoom"),
        layout["ticks"],
        layout["map_labels"]
    );
    assert_eq!(count("map"), 2, "the corridor, fused and laser-only");
    assert_eq!(count("inset-zoom"), 3);
    assert!(count("plot") >= 6);
    assert!(right - left <= f64::from(width), "{left}..{right}");
    for f in figures {
        let (l, r, w, h) = (
            f["left"].as_f64().unwrap(),
            f["right"].as_f64().unwrap(),
            f["width"].as_f64().unwrap(),
            f["height"].as_f64().unwrap(),
        );
        assert!(
            l >= left - 0.5 && r <= right + 0.5,
            "at {width} px a {} lies at {l:.0}..{r:.0}, outside the page {left:.0}..{right:.0}",
            f["kind"]
        );
        // Shrunk, not squeezed: the height follows the width.
        let (vw, vh) = (f["vb"][0].as_f64().unwrap(), f["vb"][1].as_f64().unwrap());
        assert!(
            (h / w - vh / vw).abs() < 0.02 * vh / vw + 0.01,
            "{}: {w} x {h} px for a viewBox of {vw} x {vh}",
            f["kind"]
        );
    }
    assert!(layout["ticks"].as_u64().unwrap() > 20);
    let overlaps = layout["overlaps"].as_array().unwrap();
    assert!(overlaps.is_empty(), "at {width} px: {overlaps:?}");
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
    let dir = tether_testkit::scratch("replay-report");
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
    assert_self_contained(&text);

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
    let img = screenshot(browser, &dir, &html, 1400, 4000);
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
    let distinct = grey_levels(pixels);
    assert!(distinct > 40, "{distinct}");

    // Every text of every picture apart, and every mark drawn in its legend.
    let measured = measure_texts(browser, &dir, &text, 1400);
    assert_texts_apart("replay report", &measured);
    let unlisted: Vec<&str> = measured["unlisted"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    println!(
        "replay report: {} marks drawn, {} not in their legend",
        measured["marks"],
        unlisted.len()
    );
    assert!(measured["marks"].as_u64().unwrap() > 50);
    assert!(unlisted.is_empty(), "not in the legend: {unlisted:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// What the measuring script finds of every text of every picture in Chromium's
/// layout of a page: per section (its id, or its heading), the pictures and texts
/// measured and the pairs of texts of one picture whose boxes overlap (by more than
/// half a pixel each way); legend entries of one picture sharing a colour; map labels
/// on a magnified view's square; marks drawn but not in their legend.
const MEASURE_TEXTS: &str = r#"<script>
(function () {
  const out = { sections: {}, overlaps: [], colours: [], on_squares: [], unlisted: [], marks: 0 };
  const hit = (a, b) => a.left < b.right - 0.5 && b.left < a.right - 0.5 &&
                        a.top < b.bottom - 0.5 && b.top < a.bottom - 0.5;
  const nameOf = (svg) => {
    const sec = svg.closest("section");
    if (!sec) return "page";
    if (sec.id) return sec.id;
    const h = sec.querySelector("h2");
    return h ? h.textContent : "section";
  };
  const colourOf = (e) => {
    const fill = e.getAttribute("fill"), stroke = e.getAttribute("stroke");
    return (fill && fill !== "none") ? fill : stroke;
  };
  for (const svg of document.querySelectorAll("svg")) {
    const name = nameOf(svg);
    const kind = svg.getAttribute("class") || "svg";
    const sec = out.sections[name] || (out.sections[name] = { pictures: 0, texts: 0, overlaps: 0 });
    sec.pictures += 1;
    const texts = [...svg.querySelectorAll("text")]
      .map(t => [t.textContent.trim(), t.getBoundingClientRect()])
      .filter(([t, r]) => t.length > 0 && r.width > 0 && r.height > 0);
    sec.texts += texts.length;
    for (let i = 0; i < texts.length; i++) {
      for (let j = i + 1; j < texts.length; j++) {
        if (hit(texts[i][1], texts[j][1])) {
          sec.overlaps += 1;
          out.overlaps.push(name + " " + kind + ": \"" + texts[i][0] + "\" / \"" + texts[j][0] + "\"");
        }
      }
    }
    // The colours of the legend's entries.
    let entries = [];
    if (kind === "map" && svg.querySelector("text[data-color]")) {
      entries = [...svg.querySelectorAll("text[data-color]")].map(t => [t.textContent, t.getAttribute("data-color")]);
    } else if (kind === "plot" || kind === "inset-zoom") {
      entries = [...svg.querySelectorAll("g.legend-entry")].map(g => {
        const mark = [...g.children].find(c => c.tagName !== "text");
        return [g.querySelector("text").textContent, mark ? colourOf(mark) : ""];
      });
    }
    for (let i = 0; i < entries.length; i++) {
      for (let j = i + 1; j < entries.length; j++) {
        if (entries[i][1] === entries[j][1]) {
          out.colours.push(name + " " + kind + ": \"" + entries[i][0] + "\" and \"" + entries[j][0] + "\" both " + entries[i][1]);
        }
      }
    }
    // (A demo map's legend is inside it; the replay's map has one beside it.)
    if (kind === "map" && entries.length === 0 && !svg.parentElement.querySelector("svg.legend")) {
      out.colours.push(name + ": a map's legend names no colours");
    }
    // Labels of a map keep off the squares of the magnified views.
    const squares = [...svg.querySelectorAll("g.zoom-box rect")].map(r => r.getBoundingClientRect());
    for (const t of svg.querySelectorAll("text.map-label")) {
      if (squares.some(q => hit(q, t.getBoundingClientRect()))) {
        out.on_squares.push(name + ": \"" + t.textContent + "\"");
      }
    }
  }
  // The replay report: every mark of a snapshot or of the map in its legend.
  const classes = ["scan", "leg", "person", "track", "tentative", "target", "target-lost",
                   "robot", "velocity", "trail", "robot-path", "robot-start"];
  const check = (svg, legend) => {
    const listed = new Set(legend ? [...legend.querySelectorAll("g.legend-entry")]
      .flatMap(g => (g.getAttribute("data-marks") || "").split(" ")) : []);
    for (const e of svg.querySelectorAll(classes.map(c => "." + c).join(","))) {
      if (e.closest("svg.legend")) continue;
      const cls = classes.find(c => e.classList.contains(c));
      const key = cls === "velocity" ? cls : cls + ":" + colourOf(e);
      out.marks += 1;
      if (!listed.has(key)) out.unlisted.push(nameOf(svg) + " " + svg.getAttribute("class") + ": " + key);
    }
  };
  const shots = document.querySelector("div.snapshots");
  if (shots) {
    for (const svg of shots.querySelectorAll("svg.snapshot-map")) check(svg, shots.previousElementSibling);
  }
  for (const svg of document.querySelectorAll("svg.map")) {
    const legend = svg.parentElement.querySelector("svg.legend");
    if (legend) check(svg, legend);
  }
  const pre = document.createElement("pre");
  pre.id = "texts";
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
})();
</script>"#;

/// Chromium's measure of every text of the page `html_text` (see [`MEASURE_TEXTS`]),
/// laid out `width` px wide.
fn measure_texts(browser: &str, dir: &Path, html_text: &str, width: u32) -> Value {
    let json = measured_json(browser, dir, html_text, width, MEASURE_TEXTS, "texts");
    serde_json::from_str(
        &json
            .replace("&quot;", "\"")
            .replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&amp;", "&"),
    )
    .unwrap()
}

/// Prints the texts and overlapping pairs of each section, and fails, naming them,
/// when any texts overlap, any legend gives two entries one colour, or any map label
/// lies on a magnified view's square. Returns the sections' names.
fn assert_texts_apart(what: &str, measured: &Value) -> Vec<String> {
    let sections = measured["sections"].as_object().unwrap();
    for (name, s) in sections {
        println!(
            "{what}: {name}: {} pictures, {} texts, {} overlapping pairs",
            s["pictures"], s["texts"], s["overlaps"]
        );
    }
    let list = |key: &str| -> Vec<String> {
        measured[key]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap().to_owned())
            .collect()
    };
    let (overlaps, colours, on_squares) = (list("overlaps"), list("colours"), list("on_squares"));
    println!(
        "{what}: {} overlapping pairs of texts, {} legend entries sharing a colour, {} map labels on a magnified view's square",
        overlaps.len(),
        colours.len(),
        on_squares.len()
    );
    assert!(
        overlaps.is_empty(),
        "{what}: {} overlapping pairs of texts:\n{}",
        overlaps.len(),
        overlaps.join("\n")
    );
    assert!(colours.is_empty(), "{what}: {}", colours.join("\n"));
    assert!(on_squares.is_empty(), "{what}: {}", on_squares.join("\n"));
    sections.keys().cloned().collect()
}

/// The demo report of every scenario, fused and laser only, and of the printed
/// controller: no two texts of a picture overlap, no legend gives two entries one
/// colour, no map label lies on a magnified view's square; every run is in the
/// navigation and the summary, every measure explained under it; laser-only runs are
/// named so; the long run's plots are thinned and magnified.
#[test]
fn no_text_of_the_demo_report_overlaps_another() {
    let Some(browser) = chromium_or_skip() else {
        return;
    };
    let dir = tether_testkit::scratch("report-texts");
    tether_ok(&["demo", "--out", dir.to_str().unwrap()]);
    let text = std::fs::read_to_string(dir.join("report.html")).unwrap();
    assert_self_contained(&text);
    let measured = measure_texts(browser, &dir, &text, 1400);
    let sections = assert_texts_apart("demo report", &measured);
    let runs: Vec<String> = tether_sim::BUILTIN_NAMES
        .iter()
        .flat_map(|n| [(*n).to_owned(), format!("{n}-laser-only")])
        .chain(std::iter::once("printed-controller".to_owned()))
        .collect();
    let nav = text
        .split("<nav>")
        .nth(1)
        .unwrap()
        .split("</nav>")
        .next()
        .unwrap();
    let summary = text
        .split("<h2 id=\"summary\">")
        .nth(1)
        .unwrap()
        .split("</table>")
        .next()
        .unwrap();
    for run in &runs {
        assert!(sections.contains(run), "no pictures measured in {run}");
        assert!(
            nav.contains(&format!("href=\"#{run}\"")),
            "{run} not in the navigation"
        );
        assert!(
            summary.contains(&format!("href=\"#{run}\"")),
            "{run} not in the summary"
        );
    }
    assert_eq!(summary.matches("<tr><td>").count(), runs.len());
    // Every measure explained, MOTA's sign too.
    let definitions = text
        .split("<dl class=\"measures\" id=\"measures\">")
        .nth(1)
        .unwrap()
        .split("</dl>")
        .next()
        .unwrap();
    for term in [
        "NEES",
        "MOTA",
        "MOTP",
        "ID switches",
        "RMS jerk",
        "in band",
        "RMSE",
    ] {
        assert!(
            definitions.contains(&format!("<dt>{term}")),
            "{term} undefined"
        );
    }
    assert!(definitions.contains("<b>negative</b>"), "{definitions}");
    // A laser-only run: named so in its row and its section, no "what fusion buys".
    for name in tether_sim::BUILTIN_NAMES {
        let section = text
            .split(&format!("<section id=\"{name}-laser-only\">"))
            .nth(1)
            .unwrap()
            .split("</section>")
            .next()
            .unwrap();
        assert!(!section.contains("What fusion buys"), "{name}-laser-only");
        assert!(
            section.contains("Laser only: no fusion to magnify"),
            "{name}"
        );
        assert!(
            section.contains("</a></td><td>laser only</td>"),
            "{name}-laser-only's row"
        );
    }
    // The ten-minute run: its plots thinned to the plot's pixel columns, and each
    // magnified.
    let park = text
        .split("<section id=\"outdoor_follow\">")
        .nth(1)
        .unwrap()
        .split("</section>")
        .next()
        .unwrap();
    assert_eq!(park.matches("class=\"figure zoom\"").count(), 3);
    let most = park
        .split("class=\"plot\"")
        .skip(1)
        .flat_map(|plot| {
            let plot = plot.split("</svg>").next().unwrap();
            plot.split("<polyline points=\"")
                .skip(1)
                .map(|p| p.split('"').next().unwrap().split(' ').count())
                .collect::<Vec<_>>()
        })
        .max()
        .unwrap();
    println!("outdoor_follow: at most {most} points in a plot's line");
    assert!(most <= 2 * 692 + 2, "{most}");
    let _ = std::fs::remove_dir_all(&dir);
}
