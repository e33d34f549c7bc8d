//! The decisions of cross-camera association (docs/association.md), each a named function with
//! its constants, so that SQL (sql/stages/merge.sql) only joins.
//!
//! Two tracks of one road user in two cameras differ by noise plus a constant offset `b` (a
//! detector's ground point seen from two sides, a ground-plane calibration error: issue 38);
//! two neighbours walking side by side also differ by a nearly constant offset. What tells them
//! apart is measured: the residual after removing `b` against the noise ([`pair`]), and `b`
//! itself against the offsets of the camera pair's unambiguous matches of that class
//! ([`bias`]: a bias state, mean and covariance, estimated robustly).
//!
//! | file | SQL | what |
//! |---|---|---|
//! | [`pair`] | `pair_evidence` | a candidate's offset, residual, gates and negative log-likelihood |
//! | [`bias`] | `bias_state` | a camera pair's (and class's) offset distribution, robustly |
//! | [`bias_between`] | `bias_state_between` | the state of a class without enough anchors, from the other classes' states |

pub mod bias;
pub mod bias_between;
pub mod pair;

/// The 0.999 quantile of chi-square with 2 degrees of freedom, `−2 ln 0.001`: the gate of an
/// offset's squared Mahalanobis distance from its bias state (one wrong refusal in a thousand
/// true pairs).
pub const BIAS_GATE_D2: f64 = 13.815510557964274;

/// The standard normal 0.999 quantile (the residual gate's one-sided level).
pub const Z_999: f64 = 3.090232306167813;

/// The ground-plane error the candidate search allows for (m): 2 % at 50 m from a camera.
pub const SEARCH_GROUND_PLANE_M: f64 = 1.0;

/// How far apart two cameras' reported points of one road user of `class` can lie (m), for the
/// candidate search only (LCSS proposes pairs within the camera pair's epsilon plus this; the
/// tests of [`pair`] decide). A detector's ground point lies on the road user's outline, so two
/// views differ by at most its length: a car 5 m, a bus or truck 12 m, a two-wheeler 2 m, a
/// pedestrian 1 m; plus [`SEARCH_GROUND_PLANE_M`]. A class named otherwise is searched as a car
/// (the class names of the input are the analyst's: `pedestrian`, `person`, `bicycle`, `truck`,
/// ... are recognised by their words).
pub fn search_reach_m(class: &str) -> f64 {
    class_length_m(class) + SEARCH_GROUND_PLANE_M
}

/// What kind of road user a class name means, recognised by its words: two-wheelers first (a
/// 'pedelec' or a 'pedal_cycle' is not a pedestrian), then pedestrians (`ped`, `person`, `walk`,
/// ...), heavy vehicles (`heavy`, `truck`, `bus`, `lorry`, `tram`, ...), anything else a car. The
/// class names of the input are the analyst's; this is the one place that reads them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Pedestrian,
    TwoWheeler,
    Car,
    Heavy,
    /// A class name that says nothing (`unknown`, the load's class when the input has none, `''`,
    /// `object`, `other`): sized as a car where a size must not be too small (association's reach),
    /// as the smallest road user where a size must not be too large (two bodies' least gap, a
    /// still road user's extent).
    Unknown,
}

/// Class names that say nothing of the road user.
const UNKNOWN_NAMES: &[&str] = &["", "unknown", "object", "other", "unclassified", "none", "null", "na", "n/a"];

impl Kind {
    pub fn of(class: &str) -> Kind {
        let c = class.trim().to_ascii_lowercase();
        if UNKNOWN_NAMES.contains(&c.as_str()) {
            return Kind::Unknown;
        }
        let has = |words: &[&str]| words.iter().any(|w| c.contains(w));
        // (two-wheelers first: 'moped' and 'pedelec' hold "ped" and are no pedestrians)
        if has(&["cycl", "bike", "bicycl", "motor", "scooter", "two_wheel", "two-wheel", "pedelec", "moped", "mofa", "vespa"]) {
            Kind::TwoWheeler
        } else if has(&["ped", "person", "walk", "people", "human"]) {
            Kind::Pedestrian
        } else if has(&["heavy", "truck", "bus", "lorry", "trailer", "tram", "coach"]) {
            Kind::Heavy
        } else {
            Kind::Car
        }
    }

    /// The kind's name in SQL (`class_kind`): pedestrian, two_wheeler, car, heavy.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Pedestrian => "pedestrian",
            Kind::TwoWheeler => "two_wheeler",
            Kind::Car => "car",
            Kind::Heavy => "heavy",
            Kind::Unknown => "unknown",
        }
    }

    /// Length (m): a pedestrian 1 m (a stride), a two-wheeler 2 m, a car 5 m, a bus or truck 12 m.
    pub fn length_m(self) -> f64 {
        match self {
            Kind::Pedestrian => 1.0,
            Kind::TwoWheeler => 2.0,
            Kind::Car | Kind::Unknown => 5.0,
            Kind::Heavy => 12.0,
        }
    }

    /// The largest extent (m) of a road user that never moved ([`crate::traj::stationary`]): its
    /// length; an unknown kind's is a pedestrian's (a car's 5 m would call people who stand
    /// chatting parked: 22 of the DUT intersection's road users without a class column, 2 with).
    pub fn still_extent_m(self) -> f64 {
        match self {
            Kind::Unknown => Kind::Pedestrian.length_m(),
            k => k.length_m(),
        }
    }

    /// The road user as a disc for time-to-collision (m; conflict::ttc: two road users are in
    /// contact when their centres come within the sum of their radii): half its width, a
    /// pedestrian 0.25 m (shoulders 0.5 m), a two-wheeler 0.35 m (rider and handlebar), a car
    /// 0.9 m, a bus or truck 1.275 m; an unknown kind 1 m (a pair 2 m: conflicts()' radius before
    /// issue 39). The disc is the side-by-side contact: nose to tail the bodies meet while the
    /// centres are a length apart, so a rear-end TTC is later than the bumpers' (a disc of half
    /// the length would put two pedestrians walking side by side 0.8 m apart in contact: TTC 0
    /// for every pedestrian pair of the DUT intersection's top 10 at the old 2 m).
    pub fn radius_m(self) -> f64 {
        match self {
            Kind::Pedestrian => 0.25,
            Kind::TwoWheeler => 0.35,
            Kind::Car => 0.9,
            Kind::Heavy => 1.275,
            Kind::Unknown => 1.0,
        }
    }

    /// The least distance (m) between the centres of two distinct road users of this kind: a
    /// pedestrian's torso depth, 0.25 m (two people shoulder to shoulder, or one right behind
    /// the other; measured on the DUT intersection: pedestrians walking in pairs 0.32 m apart and
    /// more at the median, one pedestrian split in two 0.03-0.14 m), a bicycle's handlebar 0.6 m,
    /// a car's width 1.8 m, a bus's or truck's 2.55 m (the EU's and the US's largest legal width).
    pub fn min_gap_m(self) -> f64 {
        match self {
            Kind::Pedestrian | Kind::Unknown => 0.25,
            Kind::TwoWheeler => 0.6,
            Kind::Car => 1.8,
            Kind::Heavy => 2.55,
        }
    }
}

/// The radius (m) of a road user of `class` as a disc for time-to-collision ([`Kind::radius_m`]):
/// two road users are in contact when their centres come within the sum of their radii.
pub fn class_radius_m(class: &str) -> f64 {
    Kind::of(class).radius_m()
}

/// The length of a road user of `class` (m, [`Kind::length_m`]). A detector's ground point lies
/// on the road user's outline, so two cameras' points of one road user differ by at most this
/// ([`search_reach_m`]), and a class's systematic offset between two views scales with it
/// (align's registration weighs the classes' disagreement by it).
pub fn class_length_m(class: &str) -> f64 {
    Kind::of(class).length_m()
}

/// The least centre distance of two distinct road users of `class` (m, [`Kind::min_gap_m`]): two
/// road users of the class whose centres stay closer than this are one body counted twice
/// (conflict::together).
pub fn class_min_gap_m(class: &str) -> f64 {
    Kind::of(class).min_gap_m()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn search_reach_by_class_words() {
        assert_eq!(search_reach_m("pedestrian"), 2.0);
        assert_eq!(search_reach_m("Person"), 2.0);
        assert_eq!(search_reach_m("cyclist"), 3.0);
        assert_eq!(search_reach_m("motorcycle"), 3.0);
        assert_eq!(class_length_m("pedelec"), 2.0);
        assert_eq!(Kind::of("moped"), Kind::TwoWheeler);
        assert_eq!(Kind::of("Moped_rider"), Kind::TwoWheeler);
        assert_eq!(class_length_m("pedal_cycle"), 2.0);
        assert_eq!(search_reach_m("heavy_vehicle"), 13.0);
        assert_eq!(search_reach_m("BUS"), 13.0);
        assert_eq!(search_reach_m("car"), 6.0);
        assert_eq!(search_reach_m("kart"), 6.0);
        assert_eq!(search_reach_m(""), 6.0);
    }
}
