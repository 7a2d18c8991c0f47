//! A robot whose collision geometry is already spheres (a spherized URDF
//! loaded as the robot) keeps those spheres as its automatic sphere model.

mod common;

use common::shared;

use ferrobot_collision::RobotSpheres;
use ferrobot_collision::spherize::{SpherizeOptions, spherize_robot};
use ferrobot_model::{LoadOptions, RobotModel};

#[test]
fn spherized_urdf_keeps_its_spheres() {
    for rel in [
        "robots/panda/panda_spherized.urdf",
        "robots/ur5/ur5_spherized.urdf",
    ] {
        let path = shared(rel);
        let model = RobotModel::from_urdf_file(&path, &LoadOptions::default()).unwrap();
        let reference = RobotSpheres::from_spherized_urdf(&model, &path).unwrap();
        for budget in [None, Some(reference.count() + 5)] {
            let options = SpherizeOptions {
                total_budget: budget,
                ..SpherizeOptions::default()
            };
            let (links, reports) = spherize_robot(&model, &options).unwrap();
            assert_eq!(links, reference.links, "{rel} budget {budget:?}");
            assert!(
                reports
                    .iter()
                    .all(|r| r.max_protrusion == 0.0 && r.coverage == 1.0)
            );
        }
        // A budget below the given spheres has nothing left to re-fit: fine.
        let small = SpherizeOptions {
            total_budget: Some(1),
            ..SpherizeOptions::default()
        };
        assert_eq!(spherize_robot(&model, &small).unwrap().0, reference.links);
    }
}
