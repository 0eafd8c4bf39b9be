//! A scenario with a scanner of the catalogue ([`crate::scanners`]): `tether sim
//! --scanner NAME` and the scenario key `[laser_sim] scanner = "NAME"`.

use tether_core::LaserModel;

use super::{FieldSeg, LaserSimSpec, Scenario, ScenarioError, field_name, line_col, locate};
use crate::scanners::{Scanner, UnknownScanner, scanner};

/// `scenario` (parsed from `src`) with the scanner its `[laser_sim] scanner` names,
/// the file's own `[laser]` and `[laser_sim]` keys over the scanner's figures; the
/// scenario itself when it names none. An unknown name is an error at that key.
pub(super) fn with_named_scanner(
    scenario: Scenario,
    src: &str,
    origin: &str,
) -> Result<Scenario, ScenarioError> {
    if scenario.laser_sim.scanner.is_none() {
        return Ok(scenario);
    }
    let Ok(mut file) = toml::from_str::<toml::Table>(src) else {
        return Ok(scenario);
    };
    match scanner_tables(&file) {
        None => Ok(scenario),
        Some(Err(e)) => {
            let field = vec![
                FieldSeg::Key("laser_sim".into()),
                FieldSeg::Key("scanner".into()),
            ];
            let (line, column, snippet) = line_col(src, locate(src, &field));
            Err(ScenarioError::Invalid {
                origin: origin.to_owned(),
                line,
                column,
                field: field_name(&field),
                message: e.to_string(),
                snippet,
            })
        }
        Some(Ok((laser, laser_sim))) => {
            file.insert("laser".into(), laser);
            file.insert("laser_sim".into(), laser_sim);
            toml::Value::Table(file)
                .try_into::<Scenario>()
                .map_err(|e| ScenarioError::Parse {
                    origin: origin.to_owned(),
                    line: 1,
                    column: 1,
                    message: format!("with the scanner's figures: {}", e.message().trim()),
                    snippet: String::new(),
                })
        }
    }
}

impl Scenario {
    /// Puts `scanner` on the robot: its geometry, range limits, scan period, the
    /// estimator's noise and mount height into `laser` (the mount's position and yaw
    /// stay), its true noise and no-returns into `laser_sim`, and its name into
    /// `laser_sim.scanner`; the `extra_lasers` become that scanner too, each on its own
    /// mount. Every other field stays as it was.
    pub fn apply_scanner(&mut self, scanner: &Scanner) {
        let laser = &scanner.laser;
        let lasers = std::iter::once(&mut self.laser)
            .chain(self.extra_lasers.iter_mut().map(|e| &mut e.laser));
        for model in lasers {
            model.geometry = laser.geometry;
            model.range_min_m = laser.range_min_m;
            model.range_max_m = laser.range_max_m;
            model.scan_period_s = laser.scan_period_s;
            model.noise = laser.noise.clone();
            model.mount.height_m = laser.mount.height_m;
        }
        let sim = &scanner.sim;
        let ls = &mut self.laser_sim;
        ls.dropout_prob = sim.dropout_prob;
        ls.object_beam_loss_prob = sim.object_beam_loss_prob;
        ls.long_range_dropout_prob = sim.long_range_dropout_prob;
        ls.long_range_start_m = sim.long_range_start_m;
        ls.noise = sim.noise.clone();
        ls.scanner = Some(scanner.name.to_owned());
    }

    /// Puts the scanner named `name` on the robot ([`Scenario::apply_scanner`]).
    pub fn with_scanner(mut self, name: &str) -> Result<Scenario, UnknownScanner> {
        self.apply_scanner(&scanner(name)?);
        Ok(self)
    }
}

/// The `[laser]` and `[laser_sim]` tables of a scenario that names a scanner: the
/// scanner's figures over the defaults, then every key the file sets over those (so a
/// file can name a scanner and still change one of its figures). `None` when the file
/// names no scanner; an error when the name is unknown.
pub(super) fn scanner_tables(
    file: &toml::Table,
) -> Option<Result<(toml::Value, toml::Value), UnknownScanner>> {
    let name = file.get("laser_sim")?.get("scanner")?.as_str()?;
    Some(scanner(name).map(|s| {
        let mut base = Scenario::defaults_for_tables();
        base.apply_scanner(&s);
        let mut laser =
            toml::Value::try_from(&base.laser).unwrap_or(toml::Value::Table(toml::Table::new()));
        let mut laser_sim = toml::Value::try_from(&base.laser_sim)
            .unwrap_or(toml::Value::Table(toml::Table::new()));
        if let Some(over) = file.get("laser") {
            merge(&mut laser, over);
        }
        if let Some(over) = file.get("laser_sim") {
            merge(&mut laser_sim, over);
        }
        (laser, laser_sim)
    }))
}

impl Scenario {
    /// The default `[laser]` and `[laser_sim]` (the rest is not used).
    fn defaults_for_tables() -> Scenario {
        Scenario {
            name: String::new(),
            description: String::new(),
            duration_s: 0.0,
            world: Default::default(),
            robot: Default::default(),
            laser: LaserModel::default(),
            extra_lasers: Vec::new(),
            laser_sim: LaserSimSpec::default(),
            camera: Default::default(),
            extra_cameras: Vec::new(),
            camera_sim: Default::default(),
            people: Vec::new(),
        }
    }
}

/// Writes every key of `over` into `base`, tables recursively.
fn merge(base: &mut toml::Value, over: &toml::Value) {
    match (base, over) {
        (toml::Value::Table(b), toml::Value::Table(o)) => {
            for (k, v) in o {
                match b.get_mut(k) {
                    Some(slot) => merge(slot, v),
                    None => {
                        b.insert(k.clone(), v.clone());
                    }
                }
            }
        }
        (slot, v) => *slot = v.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scanners::{SCANNER_NAMES, rplidar_a1};

    #[test]
    fn the_urg_04lx_changes_nothing_but_the_name() {
        let mut compared = 0;
        for name in crate::BUILTIN_NAMES {
            let plain = Scenario::builtin(name).unwrap();
            let mut with = plain.clone().with_scanner("urg_04lx").unwrap();
            assert_eq!(with.laser_sim.scanner.as_deref(), Some("urg_04lx"));
            // `all_round`'s scanners see 180 of the URG-04LX's 240 degrees (behind a
            // bumper): the scanner named puts back its own field of view.
            if plain.laser.geometry != LaserModel::default().geometry {
                assert_eq!(
                    with.laser.geometry,
                    LaserModel::default().geometry,
                    "{name}"
                );
                continue;
            }
            with.laser_sim.scanner = None;
            assert_eq!(with, plain, "{name}");
            compared += 1;
        }
        assert_eq!(compared, crate::BUILTIN_NAMES.len() - 1);
    }

    #[test]
    fn a_scenario_key_names_the_scanner_and_the_file_overrides_it() {
        let src = Scenario::builtin_toml("office").unwrap();
        let named = format!("{src}\n[laser_sim]\nscanner = \"rplidar_a1\"\n");
        let s = Scenario::from_toml_str(&named, "test").unwrap();
        let expected = Scenario::builtin("office")
            .unwrap()
            .with_scanner("rplidar_a1")
            .unwrap();
        assert_eq!(s, expected);
        assert_eq!(s.laser.geometry, rplidar_a1().laser.geometry);

        let tweaked = format!(
            "{src}\n[laser]\nrange_max_m = 6.0\n[laser.mount]\nheight_m = 0.4\n\
             [laser.geometry]\nclockwise = true\n[laser_sim]\nscanner = \"rplidar_a1\"\n"
        );
        let s = Scenario::from_toml_str(&tweaked, "test").unwrap();
        assert_eq!(s.laser.range_max_m, 6.0);
        assert_eq!(s.laser.mount.height_m, 0.4);
        assert!(s.laser.geometry.clockwise);
        assert_eq!(s.laser.geometry.steps_per_rev, 360);
        assert_eq!(s.laser_sim.object_beam_loss_prob, 0.25);
    }

    #[test]
    fn an_unknown_scanner_is_refused_with_the_known_names() {
        let src = Scenario::builtin_toml("office").unwrap();
        let bad = format!("{src}\n[laser_sim]\nscanner = \"lms200\"\n");
        let e = Scenario::from_toml_str(&bad, "test")
            .unwrap_err()
            .to_string();
        assert!(e.contains("laser_sim.scanner"), "{e}");
        for name in SCANNER_NAMES {
            assert!(e.contains(name), "{e}");
        }
        let e = Scenario::builtin("office")
            .unwrap()
            .with_scanner("lms200")
            .unwrap_err()
            .to_string();
        assert!(e.contains("rplidar_a1"), "{e}");
    }
}
