//! KITTI-360's classes as its 3D boxes name them, and the KITTI type each becomes.
//!
//! `<semanticId>` in `data_3d_bboxes` holds KITTI-360's *kittiId* (car 13, bicycle 18, person
//! 19, rider 20), not its `id`; the names are those of kitti360Scripts' `helpers/labels.py`
//! (`kittiId2label`). The `<label>` text of a box may differ (`pedestrian` for person) and is
//! not used. The mapping to KITTI's types:
//!
//! | KITTI-360 (kittiId)                                  | KITTI type   |
//! |------------------------------------------------------|--------------|
//! | car (13)                                             | `Car`        |
//! | truck (14), bus (34)                                 | `Truck`      |
//! | caravan (16), trailer (15)                           | `Van`        |
//! | person (19)                                          | `Pedestrian` |
//! | rider (20), bicycle (18), motorcycle (17)            | `Cyclist`    |
//! | train (33)                                           | `Tram`       |
//! | every other class                                    | (none)       |

use crate::error::{Error, Result};

/// (kittiId, KITTI-360 name, KITTI type) for every class a KITTI-360 box can carry.
pub const CLASSES: [(i64, &str, Option<&str>); 37] = [
    (1, "road", None),
    (2, "parking", None),
    (3, "sidewalk", None),
    (4, "terrain", None),
    (5, "vegetation", None),
    (6, "gate", None),
    (7, "wall", None),
    (8, "fence", None),
    (9, "sky", None),
    (10, "rail track", None),
    (11, "building", None),
    (12, "garage", None),
    (13, "car", Some("Car")),
    (14, "truck", Some("Truck")),
    (15, "trailer", Some("Van")),
    (16, "caravan", Some("Van")),
    (17, "motorcycle", Some("Cyclist")),
    (18, "bicycle", Some("Cyclist")),
    (19, "person", Some("Pedestrian")),
    (20, "rider", Some("Cyclist")),
    (21, "pole", None),
    (22, "smallpole", None),
    (23, "traffic light", None),
    (24, "traffic sign", None),
    (25, "lamp", None),
    (26, "trash bin", None),
    (27, "vending machine", None),
    (28, "box", None),
    (29, "stop", None),
    (30, "guard rail", None),
    (31, "bridge", None),
    (32, "tunnel", None),
    (33, "train", Some("Tram")),
    (34, "bus", Some("Truck")),
    (35, "unknown construction", None),
    (36, "unknown vehicle", None),
    (37, "unknown object", None),
];

/// The label type a class without a KITTI type is written as: its name, spaces as
/// underscores (a KITTI label line is split at spaces: `traffic light` is `traffic_light`).
pub fn label_type(name: &str) -> String {
    name.replace(' ', "_")
}

/// The KITTI-360 name of a kittiId, None for an id the dataset does not define.
pub fn class_name(kitti_id: i64) -> Option<&'static str> {
    CLASSES
        .iter()
        .find(|(id, _, _)| *id == kitti_id)
        .map(|(_, name, _)| *name)
}

/// The KITTI type a kittiId becomes, None for the classes KITTI has no type for.
pub fn kitti_type(kitti_id: i64) -> Option<&'static str> {
    CLASSES
        .iter()
        .find(|(id, _, _)| *id == kitti_id)
        .and_then(|(_, _, kind)| *kind)
}

/// Checks that every class `--classes` names (`all` aside) is one of [`CLASSES`]; the error
/// lists them, and a KITTI type given as a class (`Car`) is told which classes it follows
/// from.
pub fn check_named(names: &[String]) -> Result<()> {
    let Some(name) = names
        .iter()
        .map(|n| n.trim())
        .find(|n| *n != "all" && !CLASSES.iter().any(|(_, c, _)| c == n))
    else {
        return Ok(());
    };
    let of_type = |t: &str| -> Vec<&str> {
        CLASSES
            .iter()
            .filter(|(_, _, kind)| *kind == Some(t))
            .map(|(_, c, _)| *c)
            .collect()
    };
    let mut types: Vec<&str> = Vec::new();
    for kind in CLASSES.iter().filter_map(|(_, _, k)| *k) {
        if !types.contains(&kind) {
            types.push(kind);
        }
    }
    let what = if types.contains(&name) {
        format!(
            "a KITTI type, not a KITTI-360 class: KITTI's types are written without --classes, {name} from {}",
            of_type(name).join(", ")
        )
    } else {
        "not a KITTI-360 class".to_owned()
    };
    let all: Vec<&str> = CLASSES.iter().map(|(_, c, _)| *c).collect();
    Err(Error::Setup(format!(
        "--classes {name:?}: {what}; the classes are {} (or `all`); the KITTI types ({}) follow \
         from them (docs/kitti360.md)",
        all.join(", "),
        types.join(", ")
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_issue_mapping_holds_and_ids_are_unique() {
        assert_eq!(kitti_type(13), Some("Car"));
        assert_eq!(kitti_type(19), Some("Pedestrian"));
        assert_eq!(class_name(19), Some("person"));
        for id in [14, 34] {
            assert_eq!(kitti_type(id), Some("Truck"));
        }
        for id in [15, 16] {
            assert_eq!(kitti_type(id), Some("Van"));
        }
        for id in [17, 18, 20] {
            assert_eq!(kitti_type(id), Some("Cyclist"));
        }
        assert_eq!(kitti_type(33), Some("Tram"));
        assert_eq!(kitti_type(11), None);
        assert_eq!(class_name(11), Some("building"));
        assert_eq!(class_name(0), None);
        assert_eq!(class_name(38), None);
        let mut ids: Vec<i64> = CLASSES.iter().map(|c| c.0).collect();
        ids.dedup();
        assert_eq!(ids.len(), 37);
        assert!(ids.windows(2).all(|w| w[0] < w[1]));
    }
}
