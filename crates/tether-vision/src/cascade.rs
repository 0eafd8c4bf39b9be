//! A boosted cascade of Haar-feature classifiers, loaded from OpenCV's XML files (design 3.1).
//!
//! Two file layouts exist and both are read:
//!
//! - the current one written by `opencv_traincascade`
//!   (`<cascade type_id="opencv-cascade-classifier">`, sometimes without the `type_id`):
//!   `stageType`, `featureType`, `width`, `height`, `stages` (each with `stageThreshold`
//!   and `weakClassifiers` holding `internalNodes` and `leafValues`) and a shared list of
//!   `features`;
//! - the old one written by `opencv_haartraining`
//!   (`<name type_id="opencv-haar-classifier">`): `size`, and `stages` whose `trees` hold
//!   nodes with an inline `feature`, a `threshold` and `left_val`/`left_node`,
//!   `right_val`/`right_node`.
//!
//! Both become the same in-memory model, exactly as OpenCV 4.x does it (it converts the
//! old layout to the new one on load, `haar_cvt::convert` in `cascadedetect_convert.cpp`):
//!
//! - every number is read as a double and then narrowed to `f32` where OpenCV stores a
//!   float (node thresholds, leaf values, rectangle weights, stage thresholds);
//! - every stage threshold is lowered by `1e-5` in `f32` arithmetic
//!   (`THRESHOLD_EPS` in `CascadeClassifierImpl::Data::read`), so a window whose stage sum
//!   equals the trained threshold passes;
//! - a tree's `internalNodes` are `left right featureIndex threshold` quadruples; a child
//!   index `> 0` is another node of the same tree, `<= 0` is leaf number `-index`;
//! - when every tree of the cascade has one node (decision stumps) OpenCV evaluates the
//!   stump as `value < threshold ? leaf[0] : leaf[1]`, ignoring the child indices; this
//!   model does the same.
//!
//! LBP and HOG cascades, and XML files that are not cascades, are refused with an error
//! that says so. Everything read from the file is checked (indices in range, rectangles
//! inside the window, trees that terminate), so a corrupt file gives an error, never a
//! panic or an out-of-bounds read.

use std::path::{Path, PathBuf};

use roxmltree::{Document, Node};
use thiserror::Error;

/// OpenCV lowers every stage threshold by this much on load (`THRESHOLD_EPS`).
pub const STAGE_THRESHOLD_EPS: f32 = 1e-5;

/// Largest window side accepted, px. The pretrained cascades are 18..64 px; the bound only
/// keeps integer offsets far from overflow on a corrupt file.
pub const MAX_WINDOW_SIDE_PX: u32 = 1024;

/// Why a cascade's content cannot be used.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CascadeError {
    /// The text is not well-formed XML.
    #[error("not well-formed XML: {0}; a cascade file is the XML that OpenCV writes")]
    Xml(String),
    /// Well-formed XML, but not an OpenCV cascade.
    #[error(
        "not an OpenCV cascade: {why}; expected an <opencv_storage> file holding a cascade \
         of type_id \"opencv-cascade-classifier\" or \"opencv-haar-classifier\", such as \
         /usr/share/opencv4/haarcascades/haarcascade_upperbody.xml (Debian package opencv-data)"
    )]
    NotACascade {
        /// What was found instead.
        why: String,
    },
    /// A cascade, but of a kind tether does not run.
    #[error(
        "unsupported cascade: {kind}; tether runs boosted Haar cascades only \
         (the haarcascade_*.xml files), not lbpcascade_*.xml or HOG cascades"
    )]
    Unsupported {
        /// The kind that was found.
        kind: String,
    },
    /// A cascade with a missing, malformed or inconsistent part.
    #[error(
        "malformed cascade (line {line}): {what}; the file is damaged or was not written by OpenCV"
    )]
    Malformed {
        /// 1-based line in the file where the problem was found.
        line: u32,
        /// What is wrong.
        what: String,
    },
}

/// Why a cascade file cannot be loaded.
#[derive(Debug, Error)]
pub enum CascadeFileError {
    /// The file could not be read.
    #[error("cannot read cascade file {path} (check the path and permissions)")]
    Io {
        /// The file.
        path: PathBuf,
        /// The reason.
        #[source]
        source: std::io::Error,
    },
    /// The file was read but its content is not a usable cascade.
    #[error("cascade file {path}")]
    Content {
        /// The file.
        path: PathBuf,
        /// The reason.
        #[source]
        source: CascadeError,
    },
    /// The file is not text at all (an image or another binary passed as the cascade).
    #[error(
        "cascade file {path} is not an XML text file ({what}); pass OpenCV's cascade XML, \
         e.g. /usr/share/opencv4/haarcascades/haarcascade_upperbody.xml"
    )]
    NotText {
        /// The file.
        path: PathBuf,
        /// What it looks like.
        what: String,
    },
}

/// Which XML layout a cascade was read from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CascadeFormat {
    /// `opencv_traincascade`'s layout (`opencv-cascade-classifier`).
    TrainCascade,
    /// `opencv_haartraining`'s old layout (`opencv-haar-classifier`).
    HaarTraining,
}

/// One weighted rectangle of a Haar feature, in window pixels. For a tilted feature the
/// rectangle is rotated by 45 degrees about its top corner `(x, y)`: its corners are
/// `(x, y)`, `(x + w, y + w)`, `(x - h, y + h)` and `(x + w - h, y + w + h)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WeightedRect {
    /// Left (upright) or top-corner (tilted) column, px.
    pub x: i32,
    /// Top row, px.
    pub y: i32,
    /// Width, px.
    pub w: i32,
    /// Height, px.
    pub h: i32,
    /// Weight of the rectangle's pixel sum.
    pub weight: f32,
}

/// A Haar-like feature: the weighted sum of two or three rectangle sums.
#[derive(Debug, Clone, PartialEq)]
pub struct HaarFeature {
    /// The rectangles; unused ones have weight 0 and an empty rectangle.
    pub rects: [WeightedRect; 3],
    /// Rotated by 45 degrees (needs the tilted integral image).
    pub tilted: bool,
}

/// One node of a weak classifier tree.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TreeNode {
    /// Index into the cascade's features.
    pub feature: u32,
    /// Go left when the normalised feature value is below this.
    pub threshold: f32,
    /// Left child: `> 0` a node of the same tree, `<= 0` leaf `-left`.
    pub left: i32,
    /// Right child, same encoding.
    pub right: i32,
}

/// A weak classifier: a small tree (one node for a stump) and its leaf values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WeakTree {
    /// First node in [`Cascade::nodes`].
    pub first_node: u32,
    /// Number of nodes (>= 1).
    pub node_count: u32,
    /// First leaf in [`Cascade::leaves`]; the tree has `node_count + 1` leaves.
    pub first_leaf: u32,
}

/// One stage: the window passes when the sum of its weak classifiers' leaves is at least
/// the threshold.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stage {
    /// The file's threshold minus [`STAGE_THRESHOLD_EPS`], as OpenCV stores it.
    pub threshold: f32,
    /// First weak classifier in [`Cascade::trees`].
    pub first_tree: u32,
    /// Number of weak classifiers (>= 1).
    pub tree_count: u32,
}

/// A boosted Haar cascade as OpenCV 4.x holds it in memory.
#[derive(Debug, Clone, PartialEq)]
pub struct Cascade {
    format: CascadeFormat,
    window_width_px: u32,
    window_height_px: u32,
    features: Vec<HaarFeature>,
    stages: Vec<Stage>,
    trees: Vec<WeakTree>,
    nodes: Vec<TreeNode>,
    leaves: Vec<f32>,
    stump_based: bool,
    has_tilted: bool,
}

impl Cascade {
    /// Reads a cascade file (either XML layout).
    pub fn load(path: impl AsRef<Path>) -> Result<Cascade, CascadeFileError> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|source| CascadeFileError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let not_text = |what: String| CascadeFileError::NotText {
            path: path.to_path_buf(),
            what,
        };
        let text = match String::from_utf8(bytes) {
            Ok(text) if text.trim().is_empty() => {
                return Err(not_text(format!("it is empty, {} bytes", text.len())));
            }
            Ok(text) => text,
            Err(e) => {
                let bytes = e.as_bytes();
                let what = if bytes.starts_with(b"\x89PNG") {
                    "it is a PNG image".to_string()
                } else if bytes.starts_with(&[0xff, 0xd8]) {
                    "it is a JPEG image".to_string()
                } else {
                    format!(
                        "byte {} is not UTF-8: binary data",
                        e.utf8_error().valid_up_to()
                    )
                };
                return Err(not_text(what));
            }
        };
        Cascade::from_xml(&text).map_err(|source| CascadeFileError::Content {
            path: path.to_path_buf(),
            source,
        })
    }

    /// Parses the text of a cascade file (either XML layout).
    pub fn from_xml(text: &str) -> Result<Cascade, CascadeError> {
        let doc = Document::parse(text).map_err(|e| CascadeError::Xml(e.to_string()))?;
        let root = doc.root_element();
        if root.tag_name().name() != "opencv_storage" {
            return Err(CascadeError::NotACascade {
                why: format!("the root element is <{}>", root.tag_name().name()),
            });
        }
        let Some(top) = elements(root).next() else {
            return Err(CascadeError::NotACascade {
                why: "<opencv_storage> is empty".into(),
            });
        };
        let type_id = top.attribute("type_id");
        let ctx = Ctx { doc: &doc };
        if child(top, "stageType").is_some() || child(top, "featureType").is_some() {
            if let Some(t) = type_id.filter(|t| *t != "opencv-cascade-classifier") {
                return Err(CascadeError::NotACascade {
                    why: format!("<{}> has type_id \"{t}\"", top.tag_name().name()),
                });
            }
            ctx.read_traincascade(top)
        } else if child(top, "size").is_some() && child(top, "stages").is_some() {
            if let Some(t) = type_id.filter(|t| *t != "opencv-haar-classifier") {
                return Err(CascadeError::NotACascade {
                    why: format!("<{}> has type_id \"{t}\"", top.tag_name().name()),
                });
            }
            ctx.read_haartraining(top)
        } else {
            Err(CascadeError::NotACascade {
                why: match type_id {
                    Some(t) => format!(
                        "the first node <{}> has type_id \"{t}\"",
                        top.tag_name().name()
                    ),
                    None => format!(
                        "the first node <{}> has neither <stageType> nor <size>",
                        top.tag_name().name()
                    ),
                },
            })
        }
    }

    /// The XML layout the cascade was read from.
    pub fn format(&self) -> CascadeFormat {
        self.format
    }

    /// Width of the detection window the cascade was trained on, px.
    pub fn window_width_px(&self) -> u32 {
        self.window_width_px
    }

    /// Height of the detection window the cascade was trained on, px.
    pub fn window_height_px(&self) -> u32 {
        self.window_height_px
    }

    /// The Haar features referenced by the nodes.
    pub fn features(&self) -> &[HaarFeature] {
        &self.features
    }

    /// The stages, first to last.
    pub fn stages(&self) -> &[Stage] {
        &self.stages
    }

    /// All weak classifiers, stage by stage.
    pub fn trees(&self) -> &[WeakTree] {
        &self.trees
    }

    /// All tree nodes, tree by tree.
    pub fn nodes(&self) -> &[TreeNode] {
        &self.nodes
    }

    /// All leaf values, tree by tree.
    pub fn leaves(&self) -> &[f32] {
        &self.leaves
    }

    /// True when every weak classifier is a single-node stump (OpenCV's fast path, with
    /// its own leaf convention; see the module documentation).
    pub fn is_stump_based(&self) -> bool {
        self.stump_based
    }

    /// True when some feature is tilted by 45 degrees (the detector then also builds the
    /// tilted integral image).
    pub fn has_tilted_features(&self) -> bool {
        self.has_tilted
    }

    /// Checks every index and rectangle and derives the flags. Both readers end here.
    fn validated(mut self) -> Result<Cascade, CascadeError> {
        let (ww, wh) = (self.window_width_px, self.window_height_px);
        if ww < 3 || wh < 3 || ww > MAX_WINDOW_SIDE_PX || wh > MAX_WINDOW_SIDE_PX {
            return Err(malformed(
                0,
                format!(
                    "window size {ww}x{wh} px is outside 3..={MAX_WINDOW_SIDE_PX} px \
                     (the variance window excludes a 1-px border)"
                ),
            ));
        }
        for (i, f) in self.features.iter().enumerate() {
            for r in f.rects.iter().filter(|r| r.weight != 0.0) {
                if !rect_inside_window(r, f.tilted, ww as i32, wh as i32) {
                    return Err(malformed(
                        0,
                        format!(
                            "feature {i}: {}rectangle ({}, {}, {}, {}) does not fit in the \
                             {ww}x{wh} window",
                            if f.tilted { "tilted " } else { "" },
                            r.x,
                            r.y,
                            r.w,
                            r.h
                        ),
                    ));
                }
            }
        }
        let nfeatures = self.features.len();
        for (ti, t) in self.trees.iter().enumerate() {
            let n = t.node_count as i32;
            for k in 0..t.node_count {
                let node = &self.nodes[(t.first_node + k) as usize];
                if node.feature as usize >= nfeatures {
                    return Err(malformed(
                        0,
                        format!(
                            "weak classifier {ti} uses feature {} but the file has {nfeatures} features",
                            node.feature
                        ),
                    ));
                }
                for child in [node.left, node.right] {
                    // Children must point forward (so evaluation terminates) and stay
                    // inside the tree; leaves are numbered 0..=node_count.
                    let ok = if child > 0 {
                        child > k as i32 && child < n
                    } else {
                        -child <= n
                    };
                    if !ok {
                        return Err(malformed(
                            0,
                            format!(
                                "weak classifier {ti}, node {k}: child index {child} is out of \
                                 range for a tree of {n} nodes"
                            ),
                        ));
                    }
                }
            }
        }
        self.stump_based = self.trees.iter().all(|t| t.node_count == 1);
        self.has_tilted = self.features.iter().any(|f| f.tilted);
        Ok(self)
    }
}

/// Whether a (possibly tilted) rectangle lies inside a `ww x wh` window, so that every
/// integral-image corner it reads is inside the window's integral patch.
fn rect_inside_window(r: &WeightedRect, tilted: bool, ww: i32, wh: i32) -> bool {
    if r.w < 0 || r.h < 0 || r.x < 0 || r.y < 0 {
        return false;
    }
    if tilted {
        r.x - r.h >= 0 && r.x + r.w <= ww && r.y + r.w + r.h <= wh
    } else {
        r.x + r.w <= ww && r.y + r.h <= wh
    }
}

fn malformed(line: u32, what: String) -> CascadeError {
    CascadeError::Malformed { line, what }
}

/// Element children of a node (OpenCV's sequence items are `<_>` elements).
fn elements<'a, 'i>(node: Node<'a, 'i>) -> impl Iterator<Item = Node<'a, 'i>> {
    node.children().filter(|c| c.is_element())
}

/// The first element child with the given name.
fn child<'a, 'i>(node: Node<'a, 'i>, name: &str) -> Option<Node<'a, 'i>> {
    elements(node).find(|c| c.tag_name().name() == name)
}

/// Reading context: the document, for line numbers in errors.
/// A cascade's stages and trees as a reader fills them (either layout).
#[derive(Default)]
struct Boosted {
    stages: Vec<Stage>,
    trees: Vec<WeakTree>,
    nodes: Vec<TreeNode>,
    leaves: Vec<f32>,
}

impl Boosted {
    /// The cascade of these stages with `features`, checked.
    fn into_cascade(
        self,
        format: CascadeFormat,
        (window_width_px, window_height_px): (u32, u32),
        features: Vec<HaarFeature>,
    ) -> Result<Cascade, CascadeError> {
        Cascade {
            format,
            window_width_px,
            window_height_px,
            features,
            stages: self.stages,
            trees: self.trees,
            nodes: self.nodes,
            leaves: self.leaves,
            stump_based: false,
            has_tilted: false,
        }
        .validated()
    }
}

struct Ctx<'d, 'i> {
    doc: &'d Document<'i>,
}

impl<'d, 'i> Ctx<'d, 'i> {
    fn line(&self, node: Node<'_, '_>) -> u32 {
        self.doc.text_pos_at(node.range().start).row
    }

    fn err(&self, node: Node<'_, '_>, what: impl Into<String>) -> CascadeError {
        malformed(self.line(node), what.into())
    }

    fn req<'a>(&self, node: Node<'a, 'i>, name: &str) -> Result<Node<'a, 'i>, CascadeError> {
        child(node, name).ok_or_else(|| {
            self.err(
                node,
                format!("<{}> has no <{name}>", node.tag_name().name()),
            )
        })
    }

    /// The whitespace-separated numbers in a node's text (all text children joined).
    fn numbers(&self, node: Node<'_, '_>) -> Result<Vec<f64>, CascadeError> {
        let mut out = Vec::new();
        for text in node.children().filter(|c| c.is_text()) {
            for token in text.text().unwrap_or("").split_ascii_whitespace() {
                let v: f64 = token.parse().map_err(|_| {
                    self.err(
                        node,
                        format!(
                            "<{}> holds \"{token}\", not a number",
                            node.tag_name().name()
                        ),
                    )
                })?;
                if !v.is_finite() {
                    return Err(self.err(
                        node,
                        format!("<{}> holds a non-finite number", node.tag_name().name()),
                    ));
                }
                out.push(v);
            }
        }
        Ok(out)
    }

    fn number(&self, node: Node<'_, '_>) -> Result<f64, CascadeError> {
        match self.numbers(node)?.as_slice() {
            [v] => Ok(*v),
            other => Err(self.err(
                node,
                format!(
                    "<{}> should hold one number, found {}",
                    node.tag_name().name(),
                    other.len()
                ),
            )),
        }
    }

    /// An integer as OpenCV's `FileNode` gives it: integers as written, reals rounded to
    /// nearest (ties to even, `cvRound`).
    fn int_of(&self, node: Node<'_, '_>, v: f64) -> Result<i32, CascadeError> {
        let r = v.round_ties_even();
        if r.abs() > f64::from(i32::MAX / 2) {
            return Err(self.err(node, format!("integer {v} is out of range")));
        }
        Ok(r as i32)
    }

    fn text<'a>(&self, node: Node<'a, 'i>) -> &'a str {
        node.children()
            .find(|c| c.is_text())
            .and_then(|c| c.text())
            .unwrap_or("")
            .trim()
    }

    fn window_side(&self, node: Node<'_, '_>, v: f64) -> Result<u32, CascadeError> {
        let side = self.int_of(node, v)?;
        u32::try_from(side)
            .ok()
            .filter(|s| *s > 0)
            .ok_or_else(|| self.err(node, format!("window side {side} must be positive")))
    }

    /// Reads a rectangle list (`<rects>` with `<_>x y w h weight</_>` items).
    fn read_feature(&self, rects: Node<'_, '_>, tilted: bool) -> Result<HaarFeature, CascadeError> {
        let empty = WeightedRect {
            x: 0,
            y: 0,
            w: 0,
            h: 0,
            weight: 0.0,
        };
        let mut out = [empty; 3];
        let items: Vec<_> = elements(rects).collect();
        if items.is_empty() || items.len() > 3 {
            return Err(self.err(
                rects,
                format!(
                    "a Haar feature has 1 to 3 rectangles, this one has {}",
                    items.len()
                ),
            ));
        }
        for (slot, item) in out.iter_mut().zip(&items) {
            let v = self.numbers(*item)?;
            let [x, y, w, h, weight] = v.as_slice() else {
                return Err(self.err(
                    *item,
                    format!(
                        "a rectangle is \"x y width height weight\", found {} numbers",
                        v.len()
                    ),
                ));
            };
            *slot = WeightedRect {
                x: self.int_of(*item, *x)?,
                y: self.int_of(*item, *y)?,
                w: self.int_of(*item, *w)?,
                h: self.int_of(*item, *h)?,
                weight: *weight as f32,
            };
        }
        Ok(HaarFeature { rects: out, tilted })
    }

    fn tilted_flag(&self, feature: Node<'_, '_>) -> Result<bool, CascadeError> {
        match child(feature, "tilted") {
            Some(t) => Ok(self.int_of(t, self.number(t)?)? != 0),
            None => Ok(false),
        }
    }

    /// The `opencv_traincascade` layout.
    fn read_traincascade(&self, top: Node<'_, '_>) -> Result<Cascade, CascadeError> {
        let stage_type = self.req(top, "stageType")?;
        if self.text(stage_type) != "BOOST" {
            return Err(CascadeError::Unsupported {
                kind: format!(
                    "stage type \"{}\" (only BOOST exists)",
                    self.text(stage_type)
                ),
            });
        }
        let feature_type = self.req(top, "featureType")?;
        match self.text(feature_type) {
            "HAAR" => {}
            "LBP" => {
                return Err(CascadeError::Unsupported {
                    kind: "LBP (local binary pattern) features".into(),
                });
            }
            "HOG" => {
                return Err(CascadeError::Unsupported {
                    kind: "HOG features (OpenCV 3 and later refuse them too)".into(),
                });
            }
            other => {
                return Err(CascadeError::Unsupported {
                    kind: format!("feature type \"{other}\""),
                });
            }
        }
        let width_node = self.req(top, "width")?;
        let height_node = self.req(top, "height")?;
        let window_width_px = self.window_side(width_node, self.number(width_node)?)?;
        let window_height_px = self.window_side(height_node, self.number(height_node)?)?;
        let feature_params = self.req(top, "featureParams")?;
        if let Some(cats) = child(feature_params, "maxCatCount") {
            let n = self.int_of(cats, self.number(cats)?)?;
            if n > 0 {
                return Err(CascadeError::Unsupported {
                    kind: format!("categorical features (maxCatCount = {n}) with Haar features"),
                });
            }
        }

        let boosted = self.read_stages(
            top,
            ["stageThreshold", "weakClassifiers"],
            "a stage has no weak classifiers",
            |weak, b| {
                let Boosted {
                    trees,
                    nodes,
                    leaves,
                    ..
                } = b;
                let internal = self.req(weak, "internalNodes")?;
                let leaf_node = self.req(weak, "leafValues")?;
                let values = self.numbers(internal)?;
                if values.is_empty() || values.len() % 4 != 0 {
                    return Err(self.err(
                        internal,
                        format!(
                            "internalNodes holds {} numbers; it must be \"left right feature \
                             threshold\" quadruples",
                            values.len()
                        ),
                    ));
                }
                let node_count = (values.len() / 4) as u32;
                let leaf_values = self.numbers(leaf_node)?;
                if leaf_values.len() != node_count as usize + 1 {
                    return Err(self.err(
                        leaf_node,
                        format!(
                            "a tree of {node_count} nodes needs {} leaf values, found {}",
                            node_count + 1,
                            leaf_values.len()
                        ),
                    ));
                }
                trees.push(WeakTree {
                    first_node: nodes.len() as u32,
                    node_count,
                    first_leaf: leaves.len() as u32,
                });
                for q in values.chunks_exact(4) {
                    let feature = self.int_of(internal, q[2])?;
                    nodes.push(TreeNode {
                        feature: u32::try_from(feature).map_err(|_| {
                            self.err(internal, format!("feature index {feature} is negative"))
                        })?,
                        threshold: q[3] as f32,
                        left: self.int_of(internal, q[0])?,
                        right: self.int_of(internal, q[1])?,
                    });
                }
                leaves.extend(leaf_values.iter().map(|v| *v as f32));
                Ok(())
            },
        )?;

        let features_node = self.req(top, "features")?;
        let mut features = Vec::new();
        for f in elements(features_node) {
            let rects = self.req(f, "rects")?;
            features.push(self.read_feature(rects, self.tilted_flag(f)?)?);
        }
        boosted.into_cascade(
            CascadeFormat::TrainCascade,
            (window_width_px, window_height_px),
            features,
        )
    }

    /// The old `opencv_haartraining` layout, converted as OpenCV 4.x converts it: features
    /// are numbered in the order the nodes appear, leaves in the order `left_val` and
    /// `right_val` appear within each tree.
    fn read_haartraining(&self, top: Node<'_, '_>) -> Result<Cascade, CascadeError> {
        let size = self.req(top, "size")?;
        let sides = self.numbers(size)?;
        let [w, h] = sides.as_slice() else {
            return Err(self.err(size, "<size> must hold \"width height\""));
        };
        let window_width_px = self.window_side(size, *w)?;
        let window_height_px = self.window_side(size, *h)?;

        let mut features = Vec::new();
        let boosted = self.read_stages(
            top,
            ["stage_threshold", "trees"],
            "a stage has no trees",
            |tree, b| {
                let Boosted {
                    trees,
                    nodes,
                    leaves,
                    ..
                } = b;
                let first_node = nodes.len() as u32;
                let first_leaf = leaves.len() as u32;
                let mut tree_leaves = 0i32;
                for node in elements(tree) {
                    let feature_node = self.req(node, "feature")?;
                    let rects = self.req(feature_node, "rects")?;
                    let feature = features.len() as u32;
                    features.push(self.read_feature(rects, self.tilted_flag(feature_node)?)?);
                    let thr = self.req(node, "threshold")?;
                    let mut side = |val: &str, idx: &str| -> Result<i32, CascadeError> {
                        if let Some(v) = child(node, val) {
                            leaves.push(self.number(v)? as f32);
                            tree_leaves += 1;
                            Ok(-(tree_leaves - 1))
                        } else if let Some(n) = child(node, idx) {
                            self.int_of(n, self.number(n)?)
                        } else {
                            Err(self
                                .err(node, format!("a tree node has neither <{val}> nor <{idx}>")))
                        }
                    };
                    let left = side("left_val", "left_node")?;
                    let right = side("right_val", "right_node")?;
                    nodes.push(TreeNode {
                        feature,
                        threshold: self.number(thr)? as f32,
                        left,
                        right,
                    });
                }
                let node_count = nodes.len() as u32 - first_node;
                if node_count == 0 {
                    return Err(self.err(tree, "a tree has no nodes"));
                }
                if tree_leaves as u32 != node_count + 1 {
                    return Err(self.err(
                        tree,
                        format!(
                            "a tree of {node_count} nodes has {tree_leaves} leaf values; a binary \
                             tree needs {}",
                            node_count + 1
                        ),
                    ));
                }
                trees.push(WeakTree {
                    first_node,
                    node_count,
                    first_leaf,
                });
                Ok(())
            },
        )?;
        boosted.into_cascade(
            CascadeFormat::HaarTraining,
            (window_width_px, window_height_px),
            features,
        )
    }

    /// The `<stages>` of `top`, in either layout: each stage's threshold (element
    /// `names[0]`) and trees (the elements of `names[1]`, each read into the arrays by
    /// `read_tree`); a stage without trees is refused with `no_trees`, as is a cascade
    /// without stages.
    fn read_stages<'a>(
        &self,
        top: Node<'a, 'i>,
        names: [&str; 2],
        no_trees: &str,
        mut read_tree: impl FnMut(Node<'a, 'i>, &mut Boosted) -> Result<(), CascadeError>,
    ) -> Result<Boosted, CascadeError> {
        let mut b = Boosted::default();
        let stages_node = self.req(top, "stages")?;
        for stage_node in elements(stages_node) {
            let thr_node = self.req(stage_node, names[0])?;
            let threshold = self.number(thr_node)? as f32 - STAGE_THRESHOLD_EPS;
            let trees_node = self.req(stage_node, names[1])?;
            let first_tree = b.trees.len() as u32;
            for tree in elements(trees_node) {
                read_tree(tree, &mut b)?;
            }
            let tree_count = b.trees.len() as u32 - first_tree;
            if tree_count == 0 {
                return Err(self.err(trees_node, no_trees));
            }
            b.stages.push(Stage {
                threshold,
                first_tree,
                tree_count,
            });
        }
        if b.stages.is_empty() {
            return Err(self.err(stages_node, "the cascade has no stages"));
        }
        Ok(b)
    }
}

#[cfg(test)]
pub(crate) mod tests;
