//! `[laser]` or `[camera]`, or `[[laser]]` / `[[camera]]` once per sensor on a robot with
//! several (design 5.7).
//!
//! The first table is the robot's first sensor of its kind (its model is the pipeline's
//! `[laser]` or `[camera]`); each further one is an extra sensor whose data carry a
//! `frame_id` of their own, which the pipeline tells them apart by. [`Sensors`]
//! dereferences to the first, so that a robot with one scanner and one camera reads as
//! before.

use std::fmt;
use std::marker::PhantomData;
use std::ops::{Deref, DerefMut};

use serde::de::value::{MapAccessDeserializer, SeqAccessDeserializer};
use serde::de::{Error as _, MapAccess, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer};

use super::{CameraSection, LaserSection};

/// The frame of the first laser's scans when `[laser]` names none.
pub const FIRST_LASER_FRAME: &str = "laser";

/// A table of a sensor of which a robot may have several.
pub trait SensorTable: for<'de> Deserialize<'de> {
    /// The table's name (`laser`).
    const TABLE: &'static str;
    /// What one is (`scanner`).
    const WHAT: &'static str;
    /// The frame of the first one's data when it names none.
    const FIRST_FRAME: &'static str;
    /// A further one's frame, for the messages (`rear_laser`).
    const EXAMPLE_FRAME: &'static str;
    /// What an empty list means.
    const EMPTY: &'static str;
    /// The `frame_id` the table names, if any.
    fn frame_id(&self) -> Option<&str>;
}

impl SensorTable for LaserSection {
    const TABLE: &'static str = "laser";
    const WHAT: &'static str = "scanner";
    const FIRST_FRAME: &'static str = FIRST_LASER_FRAME;
    const EXAMPLE_FRAME: &'static str = "rear_laser";
    const EMPTY: &'static str = "the robot needs a scanner";
    fn frame_id(&self) -> Option<&str> {
        self.frame_id.as_deref()
    }
}

impl SensorTable for CameraSection {
    const TABLE: &'static str = "camera";
    const WHAT: &'static str = "camera";
    const FIRST_FRAME: &'static str = tether_core::FIRST_CAMERA_FRAME;
    const EXAMPLE_FRAME: &'static str = "rear_camera";
    const EMPTY: &'static str = "leave it out on a robot without a camera";
    fn frame_id(&self) -> Option<&str> {
        self.frame_id.as_deref()
    }
}

/// The robot's sensors of one kind: the first, then the others in the file's order.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensors<T> {
    first: T,
    extra: Vec<T>,
}

/// The robot's scanners.
pub type Lasers = Sensors<LaserSection>;

/// The robot's cameras.
pub type Cameras = Sensors<CameraSection>;

impl<T: SensorTable> Sensors<T> {
    /// The sensors after the first.
    pub fn extra(&self) -> &[T] {
        &self.extra
    }

    /// Every sensor, the first first.
    pub fn all(&self) -> impl Iterator<Item = &T> {
        std::iter::once(&self.first).chain(&self.extra)
    }

    /// Every sensor with the key its errors name (`laser`, then `laser[1]`, ...) and
    /// the frame of its data, the first first.
    pub fn keyed(&self) -> impl Iterator<Item = (String, &str, &T)> {
        self.all().enumerate().map(|(i, s)| {
            let key = match i {
                0 => T::TABLE.to_owned(),
                i => format!("{}[{i}]", T::TABLE),
            };
            (key, s.frame_id().unwrap_or(T::FIRST_FRAME), s)
        })
    }

    /// The frame of the first sensor's data.
    pub fn first_frame(&self) -> &str {
        self.first.frame_id().unwrap_or(T::FIRST_FRAME)
    }

    /// Checks each sensor with `check` (given the key its errors name), and that each
    /// further one has a frame of its own.
    pub(super) fn validate(
        &self,
        check: impl Fn(&T, &str) -> Result<(), (String, String)>,
    ) -> Result<(), (String, String)> {
        let mut frames: Vec<&str> = Vec::new();
        for (i, (key, frame, sensor)) in self.keyed().enumerate() {
            check(sensor, &key)?;
            let why = match sensor.frame_id() {
                Some("") => "is empty: it names the frame of the sensor's data",
                None if i > 0 => {
                    "is needed: each sensor after the first names the frame of its data"
                }
                _ => "",
            };
            if !why.is_empty() {
                return Err((
                    format!("{key}.frame_id"),
                    format!("{why} (e.g. {:?})", T::EXAMPLE_FRAME),
                ));
            }
            if frames.contains(&frame) {
                return Err((
                    format!("{key}.frame_id"),
                    format!(
                        "= {frame:?}: another {}'s frame; each needs its own",
                        T::WHAT
                    ),
                ));
            }
            frames.push(frame);
        }
        Ok(())
    }
}

impl<T> Deref for Sensors<T> {
    type Target = T;

    fn deref(&self) -> &T {
        &self.first
    }
}

impl<T> DerefMut for Sensors<T> {
    fn deref_mut(&mut self) -> &mut T {
        &mut self.first
    }
}

impl<T> From<T> for Sensors<T> {
    fn from(first: T) -> Sensors<T> {
        Sensors {
            first,
            extra: Vec::new(),
        }
    }
}

impl<'de, T: SensorTable> Deserialize<'de> for Sensors<T> {
    /// A table (`[laser]`) or an array of tables (`[[laser]]`), each read as `T`
    /// itself so that its errors name the key.
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Sensors<T>, D::Error> {
        struct OneOrMany<T>(PhantomData<T>);
        impl<'de, T: SensorTable> Visitor<'de> for OneOrMany<T> {
            type Value = Vec<T>;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(
                    f,
                    "a [{0}] table, or a [[{0}]] table per {1}",
                    T::TABLE,
                    T::WHAT
                )
            }

            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Self::Value, A::Error> {
                T::deserialize(MapAccessDeserializer::new(map)).map(|s| vec![s])
            }

            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<Self::Value, A::Error> {
                Vec::deserialize(SeqAccessDeserializer::new(seq))
            }
        }
        let mut all = d.deserialize_any(OneOrMany(PhantomData))?.into_iter();
        let first = all
            .next()
            .ok_or_else(|| D::Error::custom(format!("[[{}]] is empty: {}", T::TABLE, T::EMPTY)))?;
        Ok(Sensors {
            first,
            extra: all.collect(),
        })
    }
}
