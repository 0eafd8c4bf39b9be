//! `visualization_msgs/msg/Marker` and `MarkerArray` (what RViz and Foxglove draw) and
//! `rosgraph_msgs/msg/Clock` (simulated time), with the fields of Humble and Jazzy (the
//! two distributions' definitions are the same).

use super::*;

/// `std_msgs/ColorRGBA`, each channel in 0..1.
pub type ColorRgba = [f32; 4];

/// `visualization_msgs/msg/MeshFile`: a mesh carried in the message.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct MeshFile {
    /// File name, whose extension gives the format.
    pub filename: String,
    /// The file's bytes.
    pub data: Vec<u8>,
}

/// One `visualization_msgs/msg/Marker`.
#[derive(Debug, Clone, PartialEq)]
pub struct MarkerMsg {
    /// ROS header: the frame the pose and points are in.
    pub header: Header,
    /// Namespace; with `id`, the marker's identity.
    pub ns: String,
    /// Id within the namespace.
    pub id: i32,
    /// Shape: one of the `MarkerMsg::ARROW`... constants.
    pub marker_type: i32,
    /// `ADD` (also modifies), `DELETE` or `DELETEALL`.
    pub action: i32,
    /// Pose of the shape in `header.frame_id`.
    pub pose: Pose3,
    /// Size along x, y, z, m (for text, `z` is the letters' height).
    pub scale: [f64; 3],
    /// Colour (r, g, b, a).
    pub color: ColorRgba,
    /// How long the marker stays before it is removed, ns; 0 is for ever.
    pub lifetime_ns: i64,
    /// Whether the marker follows its frame as it moves.
    pub frame_locked: bool,
    /// Points of list and strip shapes, m.
    pub points: Vec<[f64; 3]>,
    /// Per-point colours (empty: `color` for all).
    pub colors: Vec<ColorRgba>,
    /// Texture's resource URI.
    pub texture_resource: String,
    /// Texture carried in the message.
    pub texture: CompressedImageMsg,
    /// Texture coordinates (u, v) per point.
    pub uv_coordinates: Vec<[f32; 2]>,
    /// Text of `TEXT_VIEW_FACING`.
    pub text: String,
    /// Mesh resource URI of `MESH_RESOURCE`.
    pub mesh_resource: String,
    /// Mesh carried in the message.
    pub mesh_file: MeshFile,
    /// Whether the mesh's own materials are used.
    pub mesh_use_embedded_materials: bool,
}

impl MarkerMsg {
    /// An arrow.
    pub const ARROW: i32 = 0;
    /// A box.
    pub const CUBE: i32 = 1;
    /// A sphere (an ellipsoid with unequal scales).
    pub const SPHERE: i32 = 2;
    /// A cylinder along z (an elliptic one with unequal x, y scales).
    pub const CYLINDER: i32 = 3;
    /// A polyline through `points`.
    pub const LINE_STRIP: i32 = 4;
    /// Segments between pairs of `points`.
    pub const LINE_LIST: i32 = 5;
    /// A sphere at each of `points`.
    pub const SPHERE_LIST: i32 = 7;
    /// Text that faces the viewer.
    pub const TEXT_VIEW_FACING: i32 = 9;
    /// Adds the marker, or replaces the one of the same `ns` and `id`.
    pub const ADD: i32 = 0;
    /// Removes the marker of the same `ns` and `id`.
    pub const DELETE: i32 = 2;
    /// Removes every marker (of every namespace) shown so far.
    pub const DELETEALL: i32 = 3;

    /// An `ADD` of `marker_type` at the identity pose with unit scale, opaque white,
    /// shown for ever.
    pub fn new(header: Header, ns: impl Into<String>, id: i32, marker_type: i32) -> Self {
        let texture = CompressedImageMsg {
            header: Header::new(Stamp::from_ns(0), ""),
            format: String::new(),
            data: Vec::new(),
        };
        MarkerMsg {
            header,
            ns: ns.into(),
            id,
            marker_type,
            action: Self::ADD,
            pose: Pose3::planar(0.0, 0.0, 0.0),
            scale: [1.0; 3],
            color: [1.0; 4],
            lifetime_ns: 0,
            frame_locked: false,
            points: Vec::new(),
            colors: Vec::new(),
            texture_resource: String::new(),
            texture,
            uv_coordinates: Vec::new(),
            text: String::new(),
            mesh_resource: String::new(),
            mesh_file: MeshFile::default(),
            mesh_use_embedded_materials: false,
        }
    }

    fn write(&self, w: &mut CdrWriter) -> Result<(), EncodeError> {
        self.header.write(w)?;
        w.string("ns", &self.ns)?;
        w.i32(self.id);
        w.i32(self.marker_type);
        w.i32(self.action);
        write_pose(w, &self.pose);
        w.f64_array(&self.scale);
        write_color(w, self.color);
        // A `builtin_interfaces/Duration` has the layout of a `Time`.
        w.time("lifetime", Stamp::from_ns(self.lifetime_ns))?;
        w.u8(u8::from(self.frame_locked));
        w.count("points", self.points.len())?;
        for p in &self.points {
            w.f64_array(p);
        }
        w.count("colors", self.colors.len())?;
        for &c in &self.colors {
            write_color(w, c);
        }
        w.string("texture_resource", &self.texture_resource)?;
        self.texture.write_cdr(w)?;
        w.count("uv_coordinates", self.uv_coordinates.len())?;
        for &[u, v] in &self.uv_coordinates {
            w.f32(u);
            w.f32(v);
        }
        w.string("text", &self.text)?;
        w.string("mesh_resource", &self.mesh_resource)?;
        w.string("mesh_file.filename", &self.mesh_file.filename)?;
        w.bytes("mesh_file.data", &self.mesh_file.data)?;
        w.u8(u8::from(self.mesh_use_embedded_materials));
        Ok(())
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        let header = Header::read(r)?;
        let ns = r.string("ns")?;
        let id = r.i32("id")?;
        let marker_type = r.i32("type")?;
        let action = r.i32("action")?;
        let pose = read_pose(r, "pose")?;
        let scale = r.f64_array("scale")?;
        let color = read_color(r, "color")?;
        let lifetime_ns = r.time("lifetime")?.ns();
        let frame_locked = r.u8("frame_locked")? != 0;
        let n = r.count("points", 24)?;
        let mut points = Vec::with_capacity(n);
        for _ in 0..n {
            points.push(r.f64_array("points")?);
        }
        let n = r.count("colors", 16)?;
        let mut colors = Vec::with_capacity(n);
        for _ in 0..n {
            colors.push(read_color(r, "colors")?);
        }
        let texture_resource = r.string("texture_resource")?;
        let texture = CompressedImageMsg::read_cdr(r)?;
        let n = r.count("uv_coordinates", 8)?;
        let mut uv_coordinates = Vec::with_capacity(n);
        for _ in 0..n {
            uv_coordinates.push([r.f32("uv_coordinates")?, r.f32("uv_coordinates")?]);
        }
        Ok(MarkerMsg {
            header,
            ns,
            id,
            marker_type,
            action,
            pose,
            scale,
            color,
            lifetime_ns,
            frame_locked,
            points,
            colors,
            texture_resource,
            texture,
            uv_coordinates,
            text: r.string("text")?,
            mesh_resource: r.string("mesh_resource")?,
            mesh_file: MeshFile {
                filename: r.string("mesh_file.filename")?,
                data: r.bytes("mesh_file.data")?,
            },
            mesh_use_embedded_materials: r.u8("mesh_use_embedded_materials")? != 0,
        })
    }
}

fn write_color(w: &mut CdrWriter, c: ColorRgba) {
    for x in c {
        w.f32(x);
    }
}

fn read_color(r: &mut CdrReader<'_>, field: &'static str) -> Result<ColorRgba, DecodeError> {
    Ok([r.f32(field)?, r.f32(field)?, r.f32(field)?, r.f32(field)?])
}

/// `visualization_msgs/msg/MarkerArray`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MarkerArrayMsg {
    /// The markers, applied in order (a `DELETEALL` first clears what came before).
    pub markers: Vec<MarkerMsg>,
}

impl Ros2Message for MarkerArrayMsg {
    const TYPE: &'static str = "visualization_msgs/msg/MarkerArray";
    const DEFINITION: &'static str = concat!(
        "Marker[] markers\n",
        sep!("visualization_msgs/Marker"),
        "std_msgs/Header header\n",
        "string ns\n",
        "int32 id\n",
        "int32 type\n",
        "int32 action\n",
        "geometry_msgs/Pose pose\n",
        "geometry_msgs/Vector3 scale\n",
        "std_msgs/ColorRGBA color\n",
        "builtin_interfaces/Duration lifetime\n",
        "bool frame_locked\n",
        "geometry_msgs/Point[] points\n",
        "std_msgs/ColorRGBA[] colors\n",
        "string texture_resource\n",
        "sensor_msgs/CompressedImage texture\n",
        "UVCoordinate[] uv_coordinates\n",
        "string text\n",
        "string mesh_resource\n",
        "MeshFile mesh_file\n",
        "bool mesh_use_embedded_materials\n",
        header_def!(),
        pose_def!(),
        vector3_def!(),
        sep!("std_msgs/ColorRGBA"),
        "float32 r\n",
        "float32 g\n",
        "float32 b\n",
        "float32 a\n",
        sep!("builtin_interfaces/Duration"),
        "int32 sec\n",
        "uint32 nanosec\n",
        sep!("sensor_msgs/CompressedImage"),
        "std_msgs/Header header\n",
        "string format\n",
        "uint8[] data\n",
        sep!("visualization_msgs/UVCoordinate"),
        "float32 u\n",
        "float32 v\n",
        sep!("visualization_msgs/MeshFile"),
        "string filename\n",
        "uint8[] data\n"
    );

    fn write_cdr(&self, w: &mut CdrWriter) -> Result<(), EncodeError> {
        w.count("markers", self.markers.len())?;
        for m in &self.markers {
            m.write(w)?;
        }
        Ok(())
    }

    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        // The smallest marker: a header and every fixed field, with empty strings and
        // sequences.
        let n = r.count("markers", 194)?;
        let mut markers = Vec::with_capacity(n);
        for _ in 0..n {
            markers.push(MarkerMsg::read(r)?);
        }
        Ok(MarkerArrayMsg { markers })
    }
}

/// `rosgraph_msgs/msg/Clock`: the simulated time on `/clock`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClockMsg {
    /// The time now.
    pub clock: Stamp,
}

impl Ros2Message for ClockMsg {
    const TYPE: &'static str = "rosgraph_msgs/msg/Clock";
    const DEFINITION: &'static str = concat!("builtin_interfaces/Time clock\n", time_def!());

    fn write_cdr(&self, w: &mut CdrWriter) -> Result<(), EncodeError> {
        w.time("clock", self.clock)
    }

    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        Ok(ClockMsg {
            clock: r.time("clock")?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_marker_array_round_trips_and_refuses_truncation() {
        let mut m = MarkerMsg::new(
            Header::new(Stamp::from_ns(5), "odom"),
            "tracks",
            3,
            MarkerMsg::SPHERE_LIST,
        );
        m.points = vec![[1.0, 2.0, 0.0], [3.0, -1.0, 0.5]];
        m.colors = vec![[0.1, 0.2, 0.3, 1.0]];
        m.lifetime_ns = 1_500_000_000;
        m.text = "#3".into();
        let msg = MarkerArrayMsg {
            markers: vec![m.clone(), m],
        };
        let bytes = to_cdr(&msg).unwrap();
        assert_eq!(from_cdr::<MarkerArrayMsg>(&bytes).unwrap(), msg);
        for cut in [4, 9, bytes.len() / 2, bytes.len() - 1] {
            assert!(from_cdr::<MarkerArrayMsg>(&bytes[..cut]).is_err(), "{cut}");
        }
        let clock = ClockMsg {
            clock: Stamp::from_ns(12_000_000_345),
        };
        assert_eq!(
            from_cdr::<ClockMsg>(&to_cdr(&clock).unwrap()).unwrap(),
            clock
        );
    }

    #[test]
    fn the_minimum_marker_length_is_a_lower_bound() {
        let m = MarkerMsg::new(Header::new(Stamp::from_ns(0), ""), "", 0, 0);
        let one = to_cdr(&MarkerArrayMsg { markers: vec![m] }).unwrap();
        // Encapsulation and count, then the marker.
        assert!(one.len() - 8 >= 194, "{}", one.len());
    }
}
