//! Annotation files in OpenCV's `info.dat` format, as `opencv_annotation` writes them and
//! `opencv_createsamples -info` reads them: one image per line,
//!
//! ```text
//! path count x y w h [x y w h ...]
//! ```
//!
//! with `path` relative to the file's folder (or absolute) and boxes in pixels, top-left
//! origin. Blank lines and lines starting with `#` are skipped.

use std::path::{Path, PathBuf};

use tether_vision::Rect;
use thiserror::Error;

/// Why an annotation file cannot be used.
#[derive(Debug, Error)]
pub enum InfoError {
    /// The file could not be read.
    #[error("cannot read annotation file {path} (check the path and permissions)")]
    Io {
        /// The file.
        path: PathBuf,
        /// The reason.
        #[source]
        source: std::io::Error,
    },
    /// A line does not follow `path count x y w h ...`.
    #[error(
        "{path}:{line}: {what}; each line must be `IMAGE COUNT x y w h [x y w h ...]` \
         (OpenCV's info.dat, as opencv_annotation writes it)"
    )]
    Syntax {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        what: String,
    },
    /// The file holds no image.
    #[error("{0} lists no image; it must hold at least one `IMAGE COUNT x y w h ...` line")]
    Empty(PathBuf),
}

/// One annotated image.
#[derive(Debug, Clone, PartialEq)]
pub struct Annotation {
    /// The image file, resolved against the annotation file's folder.
    pub image: PathBuf,
    /// The labelled boxes, px.
    pub boxes: Vec<Rect>,
    /// 1-based line of the annotation file (for error messages).
    pub line: usize,
}

/// Reads an `info.dat` file; image paths are resolved against its folder.
pub fn read_info(path: impl AsRef<Path>) -> Result<Vec<Annotation>, InfoError> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|source| InfoError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let base = path.parent().unwrap_or(Path::new("."));
    parse_info(&text, base, path)
}

/// Parses the text of an `info.dat` file; `base` is the folder image paths are relative
/// to, `name` the file's name for error messages.
pub fn parse_info(text: &str, base: &Path, name: &Path) -> Result<Vec<Annotation>, InfoError> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let trimmed = raw.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        let err = |what: String| InfoError::Syntax {
            path: name.to_path_buf(),
            line,
            what,
        };
        let mut fields = trimmed.split_whitespace();
        let Some(image) = fields.next() else { continue };
        let numbers: Vec<&str> = fields.collect();
        let Some((count, coords)) = numbers.split_first() else {
            return Err(err(format!("`{image}` has no box count")));
        };
        let count: usize = count
            .parse()
            .map_err(|_| err(format!("box count `{count}` is not a whole number")))?;
        // Compared without multiplying: a count near 2^62 would wrap `4 * count` to a
        // small number (and then ask for a vector of that many boxes).
        if coords.len() % 4 != 0 || coords.len() / 4 != count {
            let needed = count
                .checked_mul(4)
                .map_or_else(|| "more".to_string(), |n| n.to_string());
            return Err(err(format!(
                "{count} boxes need {needed} numbers after the count, found {}",
                coords.len()
            )));
        }
        let mut values = Vec::with_capacity(coords.len());
        for c in coords {
            let v: i32 = c
                .parse()
                .map_err(|_| err(format!("`{c}` is not a whole number of pixels")))?;
            values.push(v);
        }
        let mut boxes = Vec::with_capacity(values.len() / 4);
        for (k, b) in values.chunks_exact(4).enumerate() {
            let (x, y, w, h) = (b[0], b[1], b[2], b[3]);
            if w <= 0 || h <= 0 {
                return Err(err(format!(
                    "box {} ({x} {y} {w} {h}) has a width or height that is not positive",
                    k + 1
                )));
            }
            boxes.push(Rect {
                x,
                y,
                width: w,
                height: h,
            });
        }
        out.push(Annotation {
            image: base.join(image),
            boxes,
            line,
        });
    }
    if out.is_empty() {
        return Err(InfoError::Empty(name.to_path_buf()));
    }
    Ok(out)
}

/// The top `frac` of a box (an upper-body box from a whole-person label): same top, left
/// and width, height `round(h frac)` (at least 1 px). `frac` must be in `(0, 1]`.
pub fn upper_part(b: &Rect, frac: f64) -> Rect {
    let h = ((f64::from(b.height) * frac).round() as i32).max(1);
    Rect { height: h, ..*b }
}

/// Intersection over union of two boxes (0 when both are empty).
pub fn iou(a: &Rect, b: &Rect) -> f64 {
    let inter = a.intersect(b).area() as f64;
    let union = (a.area() + b.area()) as f64 - inter;
    if union > 0.0 { inter / union } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn parse(text: &str) -> Result<Vec<Annotation>, InfoError> {
        parse_info(text, Path::new("/data"), Path::new("info.dat"))
    }

    #[test]
    fn a_box_count_that_would_wrap_is_refused_not_allocated() {
        // 4 * 2^62 wraps to 0 in a release build: once "capacity overflow" in
        // `eval-cascade` and `train-cascade`.
        let e = parse("a.jpg 4611686018427387904\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("info.dat:1") && e.contains("found 0"), "{e}");
        let e = parse(&format!("a.jpg {}\n", usize::MAX))
            .unwrap_err()
            .to_string();
        assert!(e.contains("need more numbers"), "{e}");
    }

    proptest::proptest! {
        /// Any text is parsed or refused, never a panic, and what is parsed holds
        /// exactly the boxes the lines list.
        #[test]
        fn any_text_parses_or_is_refused(
            lines in proptest::collection::vec(
                ("[a-z]{1,3}\\.jpg", proptest::collection::vec(
                    proptest::prop_oneof![
                        (-5_i64..60).prop_map(|v| v.to_string()),
                        proptest::num::u64::ANY.prop_map(|v| v.to_string()),
                        "[0-9a-z#.-]{1,4}",
                    ],
                    0..10,
                )),
                0..6,
            )
        ) {
            let text: String = lines
                .iter()
                .map(|(image, fields)| format!("{image} {}\n", fields.join(" ")))
                .collect();
            if let Ok(annotations) = parse(&text) {
                for a in &annotations {
                    let (_, fields) = &lines[a.line - 1];
                    proptest::prop_assert_eq!(fields.len(), 1 + 4 * a.boxes.len());
                }
            }
        }
    }

    #[test]
    fn reads_opencv_annotation_lines() {
        let a = parse(
            "frames/a.jpg 2 491 149 49 98 238 209 58 116\n\n# comment\nb.png 0\n/abs/c.jpg 1 0 0 5 6\n",
        )
        .unwrap();
        assert_eq!(a.len(), 3);
        assert_eq!(a[0].image, Path::new("/data/frames/a.jpg"));
        assert_eq!(
            a[0].boxes[1],
            Rect {
                x: 238,
                y: 209,
                width: 58,
                height: 116
            }
        );
        assert_eq!(a[0].line, 1);
        assert!(a[1].boxes.is_empty());
        assert_eq!(a[1].line, 4);
        assert_eq!(a[2].image, Path::new("/abs/c.jpg"));
    }

    #[test]
    fn bad_lines_say_where_and_what() {
        let cases = [
            ("a.jpg\n", "no box count"),
            ("a.jpg two 1 2 3 4\n", "not a whole number"),
            ("a.jpg 2 1 2 3 4\n", "need 8 numbers"),
            ("a.jpg 1 1 2 3\n", "need 4 numbers"),
            ("a.jpg 1 1 2 3.5 4\n", "`3.5`"),
            ("a.jpg 1 1 2 0 4\n", "not positive"),
            ("a.jpg 1 1 2 -3 4\n", "not positive"),
        ];
        for (text, want) in cases {
            let e = parse(&format!("ok.jpg 0\n{text}")).unwrap_err();
            let msg = e.to_string();
            assert!(msg.contains("info.dat:2"), "{msg}");
            assert!(msg.contains(want), "{text:?}: {msg}");
        }
        assert!(matches!(parse("# nothing\n\n"), Err(InfoError::Empty(_))));
        let e = read_info("/nonexistent/info.dat").unwrap_err();
        assert!(e.to_string().contains("/nonexistent/info.dat"), "{e}");
    }

    #[test]
    fn upper_part_and_iou() {
        let b = Rect {
            x: 10,
            y: 20,
            width: 50,
            height: 100,
        };
        let u = upper_part(&b, 0.4);
        assert_eq!((u.x, u.y, u.width, u.height), (10, 20, 50, 40));
        assert!((iou(&b, &b) - 1.0).abs() < 1e-12);
        assert!((iou(&b, &u) - 0.4).abs() < 1e-12);
        let far = Rect { x: 500, ..b };
        assert_eq!(iou(&b, &far), 0.0);
    }

    proptest::proptest! {
        /// Any line of printable words either parses or gives an error; never a panic.
        #[test]
        fn arbitrary_lines_never_panic(words in proptest::collection::vec("[-a-z0-9./]{0,6}", 0..12)) {
            let _ = parse(&words.join(" "));
        }

        /// Formatting boxes and parsing them back gives the same boxes.
        #[test]
        fn round_trip(boxes in proptest::collection::vec((0i32..700, 0i32..500, 1i32..200, 1i32..200), 0..6)) {
            let mut line = format!("img.jpg {}", boxes.len());
            for (x, y, w, h) in &boxes {
                line.push_str(&format!(" {x} {y} {w} {h}"));
            }
            let a = parse(&line).unwrap();
            let got: Vec<(i32, i32, i32, i32)> = a[0].boxes.iter().map(|b| (b.x, b.y, b.width, b.height)).collect();
            proptest::prop_assert_eq!(got, boxes);
        }
    }
}
