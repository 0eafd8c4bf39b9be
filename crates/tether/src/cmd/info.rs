//! `tether info`: what a recording (a ROS 1 bag or an MCAP file) holds, topic by topic:
//! message type, count, rate, the frame ids of the headers and, for laser scans, the
//! scan geometry; and for the whole file its format, size, time span and whether it
//! was read whole. The reading is `tether_recording::inspect`'s; this prints it, as a
//! table or as JSON.
//!
//! A recording cut short (a killed recorder, an interrupted copy) is read up to the
//! cut, as every command reads it, and said to be so. A file whose structure is damaged
//! part way is described up to the damage, then the command fails naming it.

use std::path::PathBuf;

use serde_json::{Value, json};
use tether_core::Stamp;
use tether_recording::inspect::{Format, Info, ScanGeometry, TopicInfo, inspect};

/// Options of `tether info`.
///
/// `--json` prints one JSON document (pretty-printed) with these fields:
///
/// - `file` (string): the path given.
/// - `format`: `"ros1_bag"` or `"mcap"`; `format_name`: `"ROS 1 bag 2.0"` or `"MCAP"`.
/// - `profile`, `library` (strings, MCAP only, else `null`): the MCAP header's profile
///   (`ros2` for ROS 2 recordings) and the library that wrote the file.
/// - `chunks` (number, ROS 1 bags only, else `null`): chunks listed in the bag's index
///   (0 when the index was not used).
/// - `size_bytes` (number): size of the file.
/// - `start_ns`, `end_ns` (numbers or `null` without messages): earliest and latest log
///   time (the time the recorder received a message; the record time of a ROS 1 bag),
///   nanoseconds since the Unix epoch; `start_utc`, `end_utc` the same as
///   `YYYY-MM-DDTHH:MM:SS.nnnnnnnnnZ`; `duration_s` (number or `null`): end - start.
/// - `messages` (number): messages read, all topics.
/// - `read` (object): how the file was read. `status` is `"whole"` (index or summary
///   used, every record read), `"salvaged"` (no usable index or summary: every record
///   read by walking the file, which is whole), `"cut_short"` (walked up to where the
///   file ends inside a record: what comes before it is counted) or `"damaged"` (the
///   walk stopped at damage to the file's structure; the command then exits non-zero);
///   `whole` (bool): status is `"whole"`; `index_unused` (string or `null`): why the
///   index (bag) or summary (MCAP) was not used; `cut` (string or `null`): where the
///   file is cut short; `error` (string or `null`): the damage that stopped the walk;
///   `unattributed_records` (number): message records on no known connection/channel,
///   skipped.
/// - `topics` (array, sorted by topic name), each an object: `topic`; `type` (the
///   message type as the file names it, e.g. `sensor_msgs/LaserScan` in a ROS 1 bag,
///   `sensor_msgs/msg/LaserScan` in ROS 2 MCAP; several distinct ones joined by `" | "`);
///   `count` (number of messages); `first_ns`, `last_ns` (log times, or `null`);
///   `rate_hz` (`(count - 1) / (last - first)`, `null` with fewer than two messages or no
///   time between them); `has_header` (bool: the type's definition starts with a
///   `std_msgs/Header`); `frame_ids` (array of the first few distinct header frame ids,
///   at most 4); `more_frame_ids` (bool: more distinct ones were seen); `bad_headers`
///   (number of messages whose header did not decode); `scan` (laser scan topics only,
///   else `null`, also `null` when no scan decodes): the first scan that decodes,
///   `beams` (number of ranges), `angle_min_deg`, `angle_max_deg`, `fov_deg`
///   (`angle_max - angle_min`), `angle_increment_deg`, `angle_increment_rad`,
///   `range_min_m`, `range_max_m`, `scan_time_s`, `frame_id`; `bad_scans` (number of
///   scans that did not decode before the first that did).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The recording: a ROS 1 bag (format 2.0) or an MCAP file, told apart by their
    /// first bytes.
    pub recording: PathBuf,
    /// Print one JSON document for scripts instead of the table: file, format,
    /// size_bytes, start_ns, end_ns, duration_s, messages, read {status, ...}, topics
    /// [{topic, type, count, rate_hz, frame_ids, scan, ...}].
    #[arg(long)]
    pub json: bool,
}

/// Prints what the recording holds.
pub fn run(args: Args) -> anyhow::Result<()> {
    let info = inspect(&args.recording)?;
    if args.json {
        let doc = serde_json::to_string_pretty(&info_json(&info))?;
        tether::outln!("{doc}")?;
    } else {
        print_table(&info)?;
    }
    if let Some(error) = &info.read.error {
        anyhow::bail!(
            "{} is damaged: {error}; what is shown is what comes before the damage",
            args.recording.display()
        );
    }
    Ok(())
}

/// A float for JSON: NaN and infinities (which JSON cannot hold) become `null`.
fn finite(x: f64) -> Value {
    if x.is_finite() { json!(x) } else { Value::Null }
}

/// A scan's geometry as `--json` gives it.
fn scan_json(g: &ScanGeometry) -> Value {
    json!({
        "beams": g.beams,
        "angle_min_deg": finite(g.angle_min_rad.to_degrees()),
        "angle_max_deg": finite(g.angle_max_rad.to_degrees()),
        "fov_deg": finite(g.fov_deg()),
        "angle_increment_deg": finite(g.angle_increment_rad.to_degrees()),
        "angle_increment_rad": finite(g.angle_increment_rad),
        "range_min_m": finite(g.range_min_m),
        "range_max_m": finite(g.range_max_m),
        "scan_time_s": finite(g.scan_time_s),
        "frame_id": g.frame_id,
    })
}

/// The `--json` document.
fn info_json(info: &Info) -> Value {
    let (format, profile, library, chunks) = match &info.format {
        Format::Bag { chunks } => ("ros1_bag", None, None, Some(*chunks)),
        Format::Mcap { profile, library } => {
            ("mcap", Some(profile.as_str()), Some(library.as_str()), None)
        }
    };
    let topics: Vec<Value> = info
        .topics
        .iter()
        .map(|(name, t)| {
            json!({
                "topic": name,
                "type": t.type_name(),
                "count": t.count,
                "first_ns": t.first.map(Stamp::ns),
                "last_ns": t.last.map(Stamp::ns),
                "rate_hz": t.rate_hz(),
                "has_header": t.has_header,
                "frame_ids": t.frames,
                "more_frame_ids": t.more_frames,
                "bad_headers": t.bad_headers,
                "scan": t.scan.as_ref().map(scan_json),
                "bad_scans": t.bad_scans,
            })
        })
        .collect();
    json!({
        "file": info.path.display().to_string(),
        "format": format,
        "format_name": info.format_name(),
        "profile": profile,
        "library": library,
        "chunks": chunks,
        "size_bytes": info.size,
        "start_ns": info.start().map(Stamp::ns),
        "end_ns": info.end().map(Stamp::ns),
        "start_utc": info.start().map(utc),
        "end_utc": info.end().map(utc),
        "duration_s": info.duration_s(),
        "messages": info.messages(),
        "read": {
            "status": info.read.status(),
            "whole": info.read.status() == "whole",
            "index_unused": info.read.index_unused,
            "cut": info.read.cut,
            "error": info.read.error,
            "unattributed_records": info.read.unattributed,
        },
        "topics": topics,
    })
}

/// A time as `YYYY-MM-DDTHH:MM:SS.nnnnnnnnnZ` (UTC, proleptic Gregorian calendar).
fn utc(t: Stamp) -> String {
    let ns = t.ns();
    let secs = ns.div_euclid(1_000_000_000);
    let frac = ns.rem_euclid(1_000_000_000);
    let days = secs.div_euclid(86_400);
    let of_day = secs.rem_euclid(86_400);
    // Days since 1970-01-01 to a civil date (H. Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}.{frac:09}Z",
        of_day / 3600,
        of_day % 3600 / 60,
        of_day % 60
    )
}

/// A size in bytes for people.
fn human_size(bytes: u64) -> String {
    const UNITS: [&str; 4] = ["KiB", "MiB", "GiB", "TiB"];
    if bytes < 1024 {
        return format!("{bytes} bytes");
    }
    let mut value = bytes as f64;
    let mut unit = "";
    for u in UNITS {
        if value < 1024.0 {
            break;
        }
        value /= 1024.0;
        unit = u;
    }
    format!("{value:.1} {unit} ({bytes} bytes)")
}

/// The frame ids of a topic, for the table.
fn frames_text(t: &TopicInfo) -> String {
    if !t.has_header {
        return "-".to_owned();
    }
    if t.frames.is_empty() {
        return "?".to_owned();
    }
    let mut text = t
        .frames
        .iter()
        .map(|f| {
            if f.is_empty() || f.contains([' ', ',', '"']) {
                format!("{f:?}")
            } else {
                f.clone()
            }
        })
        .collect::<Vec<_>>()
        .join(", ");
    if t.more_frames {
        text.push_str(", ...");
    }
    text
}

fn print_table(info: &Info) -> anyhow::Result<()> {
    let mut format = info.format_name().to_owned();
    match &info.format {
        Format::Bag { chunks } if info.read.index_unused.is_none() => format.push_str(&format!(
            ", {chunks} chunk{} in its index",
            if *chunks == 1 { "" } else { "s" }
        )),
        Format::Bag { .. } => {}
        Format::Mcap { profile, library } => {
            let profile = if profile.is_empty() { "none" } else { profile };
            format.push_str(&format!(", profile {profile}, written by {library:?}"));
        }
    }
    tether::outln!("file      {}", info.path.display())?;
    tether::outln!("format    {format}")?;
    tether::outln!("size      {}", human_size(info.size))?;
    let read = match info.read.status() {
        "whole" => "whole (through its index)".to_owned(),
        "salvaged" => format!(
            "salvaged: every record walked ({})",
            info.read.index_unused.as_deref().unwrap_or("")
        ),
        "cut_short" => format!(
            "cut short, read up to the cut: {}",
            info.read.cut.as_deref().unwrap_or("")
        ),
        _ => format!(
            "damaged, read up to the damage: {}",
            info.read.error.as_deref().unwrap_or("")
        ),
    };
    let read = if matches!(info.format, Format::Mcap { .. }) {
        read.replace("its index", "its summary")
    } else {
        read
    };
    tether::outln!("read      {read}")?;
    if info.read.unattributed > 0 {
        tether::outln!(
            "          {} message records on no known connection skipped",
            info.read.unattributed
        )?;
    }
    match (info.start(), info.end(), info.duration_s()) {
        (Some(start), Some(end), Some(duration)) => {
            tether::outln!("start     {} (Unix time {})", utc(start), secs_text(start))?;
            tether::outln!("end       {} (Unix time {})", utc(end), secs_text(end))?;
            tether::outln!("duration  {duration:.3} s")?;
        }
        _ => tether::outln!("span      no messages")?,
    }
    let topics = info.topics.len();
    tether::outln!(
        "messages  {} on {topics} topic{}",
        info.messages(),
        if topics == 1 { "" } else { "s" }
    )?;
    tether::outln!()?;
    let rows: Vec<[String; 5]> = info
        .topics
        .iter()
        .map(|(name, t)| {
            [
                name.clone(),
                t.type_name(),
                t.count.to_string(),
                t.rate_hz().map_or("-".to_owned(), |r| format!("{r:.2}")),
                frames_text(t),
            ]
        })
        .collect();
    let heading = ["topic", "type", "messages", "rate Hz", "frame ids"];
    let mut widths = heading.map(str::len);
    for row in &rows {
        for (w, cell) in widths.iter_mut().zip(row) {
            *w = (*w).max(cell.chars().count());
        }
    }
    let line = |cells: [&str; 5]| {
        format!(
            "{:<w0$}  {:<w1$}  {:>w2$}  {:>w3$}  {}",
            cells[0],
            cells[1],
            cells[2],
            cells[3],
            cells[4],
            w0 = widths[0],
            w1 = widths[1],
            w2 = widths[2],
            w3 = widths[3],
        )
    };
    tether::outln!("{}", line(heading))?;
    for row in &rows {
        tether::outln!("{}", line([&row[0], &row[1], &row[2], &row[3], &row[4]]))?;
    }
    let scans: Vec<(&String, &TopicInfo)> = info.topics.iter().filter(|(_, t)| t.is_scan).collect();
    if !scans.is_empty() {
        tether::outln!()?;
    }
    for (name, t) in scans {
        match &t.scan {
            Some(s) => tether::outln!(
                "{name}: {} beams, field of view {:.2} deg ({:.2} to {:.2}), increment {:.4} deg \
                 ({:.6} rad), ranges {} to {} m, scan time {} s",
                s.beams,
                s.fov_deg(),
                s.angle_min_rad.to_degrees(),
                s.angle_max_rad.to_degrees(),
                s.angle_increment_rad.to_degrees(),
                s.angle_increment_rad,
                round_text(s.range_min_m),
                round_text(s.range_max_m),
                round_text(s.scan_time_s),
            )?,
            None => tether::outln!("{name}: no scan decodes ({} tried)", t.bad_scans)?,
        }
    }
    Ok(())
}

/// A time as seconds since the Unix epoch, to the nanosecond.
fn secs_text(t: Stamp) -> String {
    let text = t.to_string();
    text.strip_suffix('s').unwrap_or(&text).to_owned()
}

/// A value stored as `f32`, shown with the digits that `f32` holds (0.02, not
/// 0.019999999552965164).
fn round_text(x: f64) -> String {
    format!("{}", x as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_print_in_utc() {
        assert_eq!(utc(Stamp::from_ns(0)), "1970-01-01T00:00:00.000000000Z");
        assert_eq!(
            utc(Stamp::from_ns(1_403_201_183_687_882_605)),
            "2014-06-19T18:06:23.687882605Z"
        );
        assert_eq!(
            utc(Stamp::from_ns(951_782_400_000_000_001)),
            "2000-02-29T00:00:00.000000001Z"
        );
    }
}
