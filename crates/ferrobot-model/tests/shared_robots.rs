//! Loads the robots in `../shared/robots` (beside the checkout).

use std::path::PathBuf;

use ferrobot_model::{LoadOptions, RobotModel, SrdfSource};

fn shared(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/robots")
        .join(rel)
}

#[test]
fn loads_motionbenchmaker_panda_with_srdf() {
    let model = RobotModel::from_urdf_file(
        shared("panda/panda.urdf"),
        &LoadOptions {
            srdf: Some(SrdfSource::File(shared("panda/panda.srdf"))),
            ..Default::default()
        },
    )
    .unwrap();
    let names: Vec<&str> = model.dof_names().iter().map(String::as_str).collect();
    assert_eq!(
        names,
        [
            "panda_joint1",
            "panda_joint2",
            "panda_joint3",
            "panda_joint4",
            "panda_joint5",
            "panda_joint6",
            "panda_joint7"
        ]
    );
    assert_eq!(model.links()[model.ee_link()].name, "panda_hand");
    assert!(
        model
            .links()
            .iter()
            .all(|l| l.collisions.iter().all(|g| g.shape.kind() == "mesh"))
    );
    // link6.obj has 17 sub-meshes (materials): every face must land on its own vertices.
    let link6 = &model.links()[model.link("panda_link6").unwrap()];
    let ferrobot_model::Shape::Mesh(m) = &link6.collisions[0].shape else {
        panic!("link6 collision is a mesh")
    };
    let mesh = m.data();
    let text = std::fs::read_to_string(shared("panda/meshes/collision/link6.obj")).unwrap();
    let faces = text.lines().filter(|l| l.starts_with("f ")).count();
    assert_eq!(mesh.triangles.len(), faces);
    let area: f64 = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
            (b - a).cross(&(c - a)).norm() / 2.0
        })
        .sum();
    assert!((area - 0.0987).abs() < 0.001, "link6 surface area {area}");
    let ready = model.named_state("ready", None).unwrap();
    assert_eq!(ready[3], -2.356);
    assert!(!model.disabled_collision_pairs().is_empty());
    assert_eq!(
        model.group_dof_indices("panda_arm").unwrap(),
        (0..7).collect::<Vec<_>>()
    );
}

#[test]
fn loads_ur5_with_robotiq_meshes() {
    let model = RobotModel::from_urdf_file(
        shared("ur5/ur5.urdf"),
        &LoadOptions {
            srdf: Some(SrdfSource::File(shared("ur5/ur5.srdf"))),
            ..Default::default()
        },
    )
    .unwrap();
    assert!(model.num_dof() >= 6, "{:?}", model.dof_names());
    let meshes = model
        .links()
        .iter()
        .flat_map(|l| l.collisions.iter())
        .filter(|g| g.shape.kind() == "mesh")
        .count();
    assert!(meshes > 5);
    println!(
        "ur5 dofs {:?} ee {}",
        model.dof_names(),
        model.links()[model.ee_link()].name
    );
}
