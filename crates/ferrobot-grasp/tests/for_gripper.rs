//! `DetectOptions::for_gripper` (issue 16: the pad-scaled depths moved from
//! Python into the crate). The expected depths are written out by hand from
//! each gripper's finger length: 0.8, 0.6 and 0.4 of it (0.3 dropped by
//! depth18i: hands that engage less than the pad's width, see
//! `candidates::engagement_factor`).

use ferrobot_grasp::{DetectOptions, GripperGeometry};
use ferrobot_model::Gripper;

fn close(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12)
}

#[test]
fn panda_hand_depths_are_the_defaults() {
    // Panda fingers: 50 mm -> 40, 30, 20 mm (the detector's default depths).
    let o = DetectOptions::default().for_gripper(&Gripper::panda_hand());
    assert!(close(&o.depths, &[0.04, 0.03, 0.02]), "{:?}", o.depths);
    assert!(close(&o.depths, &DetectOptions::default().depths));
    assert_eq!(o.gripper.max_width, 0.08);
    assert_eq!(o.gripper.finger_depth, 0.05);
}

#[test]
fn robotiq_depths_scale_with_its_pads_and_other_options_stay() {
    // Robotiq 2F-85 fingers: 37.5 mm -> 30, 22.5, 15 mm.
    let base = DetectOptions {
        num_seeds: 17,
        gripper: GripperGeometry {
            approach_distance: 0.07,
            clearance: 0.002,
            ..GripperGeometry::default()
        },
        ..DetectOptions::default()
    };
    let o = base.for_gripper(&Gripper::robotiq_2f85());
    assert!(close(&o.depths, &[0.03, 0.0225, 0.015]), "{:?}", o.depths);
    assert_eq!(o.gripper.finger_depth, 0.0375);
    assert!(
        (o.gripper.max_width - 0.085).abs() < 1e-3,
        "{}",
        o.gripper.max_width
    );
    // Options that are not hand geometry are the caller's.
    assert_eq!(o.num_seeds, 17);
    assert_eq!(o.gripper.approach_distance, 0.07);
    assert_eq!(o.gripper.clearance, 0.002);
    o.validate().unwrap();
}
