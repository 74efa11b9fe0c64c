//! The nominal machine a fit was identified on, as identify records it in
//! identifiability.json (`nominal`: each key of the config that sets the
//! nominal geometry, with its value), and the check that compensate,
//! export and verify make before applying identified.csv: errors
//! identified on one nominal machine mean nothing on another (a base
//! joint moved 7 mm moves what every error is relative to).

use super::inputs::checks_beside;
use crate::error::{Error, Result};
use std::path::Path;

/// The config keys that set a nominal machine and their values (a key's
/// numbers in the config's units, in its order).
pub type Nominal = Vec<(String, Vec<f64>)>;

/// `nominal` as identifiability.json records it: an object of key →
/// array of numbers, in the machine's order.
pub fn to_json(nominal: &Nominal) -> serde_json::Value {
    serde_json::Value::Object(
        nominal
            .iter()
            .map(|(k, v)| (k.clone(), serde_json::json!(v)))
            .collect(),
    )
}

/// Two values of a key agree: equal to 1e-9 of their size (or 1e-9
/// absolute), beyond any digit a config writes and within JSON's
/// round-trip; directions (`angular`, a key of angles in degrees) modulo
/// a turn (300° is −60°).
fn agree(a: f64, b: f64, angular: bool) -> bool {
    let d = match angular {
        true => (a - b + 180.0).rem_euclid(360.0) - 180.0,
        false => a - b,
    };
    d.abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0)
}

/// The first key of `here` (this config's nominal machine) whose value
/// `recorded` (identifiability.json's `nominal`) does not hold, in words
/// ("geometry.b = [288.7] where this config has [295.7]"), or a key it
/// lacks; None when every key agrees.
pub fn differs(here: &Nominal, recorded: &serde_json::Value) -> Option<String> {
    for (key, want) in here {
        let got: Option<Vec<f64>> = recorded
            .get(key)
            .and_then(|v| v.as_array())
            .and_then(|a| a.iter().map(|x| x.as_f64()).collect());
        match got {
            None => return Some(format!("has no {key}, which this config sets to {want:?}")),
            Some(g)
                if g.len() != want.len()
                    || g.iter()
                        .zip(want)
                        .any(|(a, b)| !agree(*a, *b, key.ends_with("_angles_deg"))) =>
            {
                return Some(format!("has {key} = {g:?} where this config has {want:?}"))
            }
            Some(_) => {}
        }
    }
    let keys = recorded.as_object().map_or(0, |o| o.len());
    (keys != here.len()).then(|| {
        format!(
            "records {keys} keys of the nominal machine where this config sets {}",
            here.len()
        )
    })
}

/// Refuse `identified` (an identified.csv) where identify's
/// identifiability.json beside it records another nominal machine than
/// `here` (config `source`'s): one sentence naming the key and both
/// values. Ok(None) where they agree or nothing lies beside it (a model
/// from elsewhere); Ok(Some(note)) where the file records no nominal
/// machine (an identify from before this record), which cannot be checked.
pub fn check_beside(identified: &Path, here: &Nominal, source: &str) -> Result<Option<String>> {
    let Some(json) = checks_beside(identified) else {
        return Ok(None);
    };
    let meta = std::fs::symlink_metadata(&json).ok();
    // A report, never a special file: at most a few MB are read.
    if !meta.is_some_and(|m| m.is_file() && m.len() <= 64 << 20) {
        return Ok(None);
    }
    let Some(v) = std::fs::read(&json)
        .ok()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
    else {
        return Ok(None);
    };
    let Some(recorded) = v.get("nominal") else {
        return Ok(Some(format!(
            "note: {} records no nominal machine (an identify older than this check): that identified.csv was fitted on {source}'s nominal geometry is not checked",
            json.display()
        )));
    };
    match differs(here, recorded) {
        None => Ok(None),
        Some(why) => Err(Error::csv(
            identified.display().to_string(),
            format!(
                "was identified on another nominal machine than {source}'s: {} {why}; use the config it was identified under, or identify again with this one",
                json.display()
            ),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_nominal_machine_differs_at_its_first_changed_key() {
        let here: Nominal = vec![
            ("geometry.a".into(), vec![100.0]),
            ("geometry.base_angles_deg".into(), vec![-60.0, 60.0, 180.0]),
        ];
        let same = to_json(&here);
        assert_eq!(differs(&here, &same), None);
        // Within 1e-9 of their size: the same (JSON's round trip).
        let near = serde_json::json!({"geometry.a": [100.0 + 5e-8], "geometry.base_angles_deg": [-60.0, 60.0, 180.0]});
        assert_eq!(differs(&here, &near), None);
        // A direction is the same a turn away (300° is −60°, −180° is
        // 180°); a length is not.
        let turned = serde_json::json!({"geometry.a": [100.0], "geometry.base_angles_deg": [300.0, 420.0, -180.0]});
        assert_eq!(differs(&here, &turned), None);
        let longer = serde_json::json!({"geometry.a": [460.0], "geometry.base_angles_deg": [-60.0, 60.0, 180.0]});
        assert!(differs(&here, &longer)
            .unwrap()
            .starts_with("has geometry.a"));
        let moved = serde_json::json!({"geometry.a": [100.0], "geometry.base_angles_deg": [-60.0, 67.0, 180.0]});
        assert_eq!(
            differs(&here, &moved).unwrap(),
            "has geometry.base_angles_deg = [-60.0, 67.0, 180.0] where this config has [-60.0, 60.0, 180.0]"
        );
        let short =
            serde_json::json!({"geometry.a": [100.0], "geometry.base_angles_deg": [-60.0, 60.0]});
        assert!(differs(&here, &short)
            .unwrap()
            .starts_with("has geometry.base_angles_deg"));
        let lacking = serde_json::json!({"geometry.a": [100.0]});
        assert!(differs(&here, &lacking)
            .unwrap()
            .starts_with("has no geometry.base_angles_deg"));
        let more = serde_json::json!({"geometry.a": [100.0], "geometry.base_angles_deg": [-60.0, 60.0, 180.0], "hexapod.home_pose": [0.0]});
        assert!(differs(&here, &more).unwrap().contains("records 3 keys"));
        assert!(differs(&here, &serde_json::json!({"geometry.a": ["x"]})).is_some());
    }
}
