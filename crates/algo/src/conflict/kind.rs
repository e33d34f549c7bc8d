//! What kind of conflict a crossing is: SSAM's kinds where they apply, and the kind of road
//! users otherwise (issue 39).
//!
//! SSAM (Gettman, Pu, Sayed, Shelby: *Surrogate Safety Assessment Model and Validation*,
//! FHWA-HRT-08-051, 2008, §3) sorts a conflict **between two vehicles** by the angle between
//! their headings where their paths cross: rear-end under 30°, lane change from 30° to 85°,
//! crossing over 85°. Those kinds are about vehicles in lanes: a pedestrian does not change lanes
//! nor get rear-ended in SSAM's sense, so SSAM itself leaves pedestrians out. Here:
//! - two vehicles (cars, heavy vehicles, two-wheelers: [`Kind`]): SSAM's kind by the angle;
//! - a vehicle and a pedestrian: `vehicle-pedestrian` (the kind a safety study counts apart);
//! - two pedestrians: `pedestrian-pedestrian` (not a traffic conflict: people pass close by);
//! - a class that says nothing of the road user ([`Kind::Unknown`]) or no angle: no kind (NULL).
//!   Calling two unknown road users a "lane change" would be a guess.
//!
//! The angle is `Pet::angle` (degrees, 0-180, between the two headings at the crossing); any
//! other value is folded into 0-180 (350° and -10° are 10°).
//!
//! # Complexity
//! O(length of the class names).

use crate::associate::Kind;

/// SSAM's largest angle of a rear-end conflict (degrees).
pub const REAR_END_MAX_DEG: f64 = 30.0;
/// SSAM's largest angle of a lane-change conflict (degrees); above it, crossing.
pub const LANE_CHANGE_MAX_DEG: f64 = 85.0;

/// The kind of a conflict between road users of classes `class_a` and `class_b` whose paths
/// cross at `angle_deg` (module docs); `None` when it has none.
pub fn conflict_kind(class_a: &str, class_b: &str, angle_deg: Option<f64>) -> Option<&'static str> {
    let (a, b) = (Kind::of(class_a), Kind::of(class_b));
    if a == Kind::Unknown || b == Kind::Unknown {
        return None;
    }
    match (a == Kind::Pedestrian, b == Kind::Pedestrian) {
        (true, true) => Some("pedestrian-pedestrian"),
        (true, false) | (false, true) => Some("vehicle-pedestrian"),
        (false, false) => {
            // the angle between two headings: any value folds into [0, 180] (350 is 10)
            let g = angle_deg.filter(|g| g.is_finite())?.rem_euclid(360.0);
            let g = if g > 180.0 { 360.0 - g } else { g };
            Some(if g < REAR_END_MAX_DEG {
                "rear-end"
            } else if g <= LANE_CHANGE_MAX_DEG {
                "lane-change"
            } else {
                "crossing"
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::conflict_kind;

    #[test]
    fn ssam_kinds_for_vehicles_only() {
        assert_eq!(conflict_kind("car", "truck", Some(10.0)), Some("rear-end"));
        assert_eq!(conflict_kind("car", "bicycle", Some(30.0)), Some("lane-change"));
        assert_eq!(conflict_kind("bus", "car", Some(85.0)), Some("lane-change"));
        assert_eq!(conflict_kind("car", "car", Some(90.0)), Some("crossing"));
        assert_eq!(conflict_kind("car", "car", Some(350.0)), Some("rear-end"));
        assert_eq!(conflict_kind("car", "car", Some(-10.0)), Some("rear-end"));
        assert_eq!(conflict_kind("car", "car", Some(270.0)), Some("crossing"));
        assert_eq!(conflict_kind("car", "moped", Some(300.0)), Some("lane-change"));
        // a pedestrian pair is no lane change, whatever the angle
        assert_eq!(conflict_kind("pedestrian", "person", Some(45.0)), Some("pedestrian-pedestrian"));
        assert_eq!(conflict_kind("car", "pedestrian", Some(10.0)), Some("vehicle-pedestrian"));
        assert_eq!(conflict_kind("Pedestrian", "cyclist", None), Some("vehicle-pedestrian"));
    }

    #[test]
    fn no_kind_without_classes_or_angle() {
        assert_eq!(conflict_kind("unknown", "car", Some(90.0)), None);
        assert_eq!(conflict_kind("", "", Some(10.0)), None);
        assert_eq!(conflict_kind("car", "car", None), None);
        assert_eq!(conflict_kind("car", "car", Some(f64::NAN)), None);
    }
}
