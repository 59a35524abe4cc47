//! nuScenes' categories to KITTI's types, and its visibility levels to KITTI's occlusion
//! states (docs/nuscenes.md).
//!
//! The table follows KITTI-360's (`kitti360::classes`): cars are `Car`; trucks, buses and
//! construction vehicles `Truck`; trailers `Van`; pedestrians (adults, children, construction
//! workers, police officers) `Pedestrian`; a bicycle or motorcycle `Cyclist` when its
//! attribute says it has a rider. Every other category (emergency vehicles, strollers,
//! wheelchairs, personal mobility, animals, barriers, cones, debris, bicycle racks, riderless
//! cycles) has no KITTI type.

use crate::error::{Error, Result};
use std::path::Path;

/// (category, KITTI type) of the categories that always have a type.
pub const CLASSES: [(&str, &str); 10] = [
    ("vehicle.car", "Car"),
    ("vehicle.truck", "Truck"),
    ("vehicle.bus.bendy", "Truck"),
    ("vehicle.bus.rigid", "Truck"),
    ("vehicle.construction", "Truck"),
    ("vehicle.trailer", "Van"),
    ("human.pedestrian.adult", "Pedestrian"),
    ("human.pedestrian.child", "Pedestrian"),
    ("human.pedestrian.construction_worker", "Pedestrian"),
    ("human.pedestrian.police_officer", "Pedestrian"),
];

/// The cycles, `Cyclist` with the attribute [`WITH_RIDER`].
pub const CYCLES: [&str; 2] = ["vehicle.bicycle", "vehicle.motorcycle"];

/// The attribute of a cycle with a rider.
pub const WITH_RIDER: &str = "cycle.with_rider";

/// The KITTI type of an object of `category` with `attributes`, or None.
pub fn kitti_type(category: &str, attributes: &[&str]) -> Option<&'static str> {
    if CYCLES.contains(&category) {
        return attributes.contains(&WITH_RIDER).then_some("Cyclist");
    }
    CLASSES
        .iter()
        .find(|(c, _)| *c == category)
        .map(|(_, kind)| *kind)
}

/// KITTI's occlusion state of a visibility level (the fraction of the object visible in all
/// the cameras' images): `v80-100` 0 (fully visible), `v60-80` and `v40-60` 1 (partly
/// occluded), `v0-40` 2 (largely occluded), none or another level 3 (unknown).
pub fn occlusion(level: Option<&str>) -> u8 {
    match level {
        Some("v80-100") => 0,
        Some("v60-80" | "v40-60") => 1,
        Some("v0-40") => 2,
        _ => 3,
    }
}

/// The KITTI types, each written from its categories whatever `--classes` says.
pub const KITTI_TYPES: [&str; 5] = ["Car", "Truck", "Van", "Pedestrian", "Cyclist"];

/// Checks that every category `--classes` names (`all` aside) is one of `known`, those of
/// `table` (category.json). The error lists them, and a KITTI type given as a category
/// (`Car`) is told which categories it follows from.
pub fn check_named(names: &[String], known: &[String], table: &Path) -> Result<()> {
    let Some(name) = names
        .iter()
        .map(|n| n.trim())
        .find(|n| *n != "all" && !known.iter().any(|k| k == n))
    else {
        return Ok(());
    };
    let what = if KITTI_TYPES.contains(&name) {
        let from: Vec<&str> = CLASSES
            .iter()
            .filter(|(_, kind)| *kind == name)
            .map(|(c, _)| *c)
            .chain(CYCLES.iter().copied().filter(|_| name == "Cyclist"))
            .collect();
        format!(
            "a KITTI type, not a category: KITTI's types are written without --classes, {name} from {}",
            from.join(", ")
        )
    } else {
        "not a category".to_owned()
    };
    Err(Error::Setup(format!(
        "--classes {name:?}: {what}; the categories of {} are {} (or `all`); the KITTI types ({}) \
         follow from them (docs/nuscenes.md)",
        table.display(),
        known.join(", "),
        KITTI_TYPES.join(", ")
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_maps_as_documented() {
        assert_eq!(kitti_type("vehicle.car", &[]), Some("Car"));
        for c in [
            "vehicle.truck",
            "vehicle.bus.rigid",
            "vehicle.bus.bendy",
            "vehicle.construction",
        ] {
            assert_eq!(kitti_type(c, &["vehicle.parked"]), Some("Truck"), "{c}");
        }
        assert_eq!(kitti_type("vehicle.trailer", &[]), Some("Van"));
        assert_eq!(
            kitti_type("human.pedestrian.child", &[]),
            Some("Pedestrian")
        );
        assert_eq!(kitti_type("human.pedestrian.stroller", &[]), None);
        assert_eq!(
            kitti_type("vehicle.bicycle", &["cycle.with_rider"]),
            Some("Cyclist")
        );
        assert_eq!(
            kitti_type("vehicle.motorcycle", &["cycle.without_rider"]),
            None
        );
        assert_eq!(kitti_type("vehicle.bicycle", &[]), None);
        assert_eq!(kitti_type("vehicle.emergency.police", &[]), None);
        assert_eq!(kitti_type("movable_object.barrier", &[]), None);
        assert_eq!(occlusion(Some("v80-100")), 0);
        assert_eq!(occlusion(Some("v40-60")), 1);
        assert_eq!(occlusion(Some("v0-40")), 2);
        assert_eq!(occlusion(None), 3);
    }
}
