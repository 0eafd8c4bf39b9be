//! `[laser]`, or `[[laser]]` once per scanner on a robot with several (design 5.7).
//!
//! The first table is the robot's first laser (its mount is the pipeline's `[laser]`
//! mount); each further one is an extra laser whose scans carry a `frame_id` of its
//! own, which the pipeline tells them apart by. [`Lasers`] dereferences to the first,
//! so that a robot with one scanner reads as before.

use std::fmt;
use std::ops::{Deref, DerefMut};

use serde::de::value::{MapAccessDeserializer, SeqAccessDeserializer};
use serde::de::{Error as _, MapAccess, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer};

use super::LaserSection;

/// The frame of the first laser's scans when `[laser]` names none.
pub const FIRST_LASER_FRAME: &str = "laser";

/// The robot's scanners: the first, then the others in the file's order.
#[derive(Debug, Clone, PartialEq)]
pub struct Lasers {
    first: LaserSection,
    extra: Vec<LaserSection>,
}

impl Lasers {
    /// The scanners after the first.
    pub fn extra(&self) -> &[LaserSection] {
        &self.extra
    }

    /// Every scanner, the first first.
    pub fn all(&self) -> impl Iterator<Item = &LaserSection> {
        std::iter::once(&self.first).chain(&self.extra)
    }

    /// The frame of the first scanner's scans.
    pub fn first_frame(&self) -> &str {
        self.first.frame_id.as_deref().unwrap_or(FIRST_LASER_FRAME)
    }

    /// Checks every scanner (`laser_link`: each must say where it is plugged in), and
    /// that each further one has a frame of its own.
    pub(super) fn validate(&self, laser_link: bool) -> Result<(), (String, String)> {
        self.first.validate(laser_link, "laser")?;
        let mut frames = vec![self.first_frame().to_owned()];
        for (i, l) in self.extra.iter().enumerate() {
            let key = format!("laser[{}]", i + 1);
            l.validate(laser_link, &key)?;
            match l.frame_id.as_deref() {
                None | Some("") => {
                    return Err((
                        format!("{key}.frame_id"),
                        "is needed: each scanner after the first names the frame of its \
                         scans (e.g. \"rear_laser\")"
                            .into(),
                    ));
                }
                Some(f) if frames.iter().any(|g| g == f) => {
                    return Err((
                        format!("{key}.frame_id"),
                        format!("= {f:?}: another scanner's frame; each needs its own"),
                    ));
                }
                Some(f) => frames.push(f.to_owned()),
            }
        }
        Ok(())
    }
}

impl Deref for Lasers {
    type Target = LaserSection;

    fn deref(&self) -> &LaserSection {
        &self.first
    }
}

impl DerefMut for Lasers {
    fn deref_mut(&mut self) -> &mut LaserSection {
        &mut self.first
    }
}

impl From<LaserSection> for Lasers {
    fn from(first: LaserSection) -> Lasers {
        Lasers {
            first,
            extra: Vec::new(),
        }
    }
}

impl<'de> Deserialize<'de> for Lasers {
    /// A table (`[laser]`) or an array of tables (`[[laser]]`), each read as
    /// [`LaserSection`] itself so that its errors name the key.
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Lasers, D::Error> {
        struct OneOrMany;
        impl<'de> Visitor<'de> for OneOrMany {
            type Value = Vec<LaserSection>;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a [laser] table, or a [[laser]] table per scanner")
            }

            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Self::Value, A::Error> {
                LaserSection::deserialize(MapAccessDeserializer::new(map)).map(|l| vec![l])
            }

            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<Self::Value, A::Error> {
                Vec::deserialize(SeqAccessDeserializer::new(seq))
            }
        }
        let mut all = d.deserialize_any(OneOrMany)?.into_iter();
        let first = all
            .next()
            .ok_or_else(|| D::Error::custom("[[laser]] is empty: the robot needs a scanner"))?;
        Ok(Lasers {
            first,
            extra: all.collect(),
        })
    }
}
